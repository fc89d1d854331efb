"""imu_<ID>.csv (plain or .csv.gz): raw IMU samples, read and validated (DATA.md "Raw sensors").

Two forms, one per file: rates ``time, gyro_x, gyro_y, gyro_z`` (rad/s), ``accel_x,
accel_y, accel_z`` (specific force, m/s^2), or increments ``time, dtheta_x..z`` (rad),
``dvel_x..z`` (m/s) per sample. Either way :func:`read_imu_csv` returns an
:class:`ImuData` in rates: increments are divided by the nominal sample interval (the
median interval; the IMU integrates over its own clock, so the jitter of the logged
timestamps is not in the increments). Body axes: x forward, y left, z up.

Checked, each one line naming the file (and line) and what was found:

- a missing column (with the misspelled one when there is one), both forms in one file,
  an extra column that looks like a misspelled known one; other extra columns
  (``temperature``) are ignored, with a note;
- cells that are empty, NaN, inf or text;
- times that do not strictly increase;
- the sample rate (1 / median interval) outside 50..1000 Hz (2 % slack for clock
  drift), with a hint when the times look like milliseconds, microseconds or
  nanoseconds;
- units: the median accelerometer magnitude must be near 9.81 m/s^2 (a platform on the
  ground feels gravity): near 1 reads as g, near 1000 as mg, far below as gravity
  removed; gyro rates above 35 rad/s (2000 deg/s, the largest full scale of common
  MEMS gyros) and, while the accelerometers say the unit is at rest, a rotation about a
  horizontal axis above 0.1 rad/s (it would tilt gravity by more than 5.7 deg per second,
  which the accelerometers do not see) read as deg/s.
"""

from __future__ import annotations

import difflib
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import InputError
from coopproc.frames import EARTH_RATE_RADPS
from coopproc.io._common import InputProblems, Locator, missing_column, numeric_column
from coopproc.io.csv_traj import read_csv_table
from coopproc.io.file_names import find_sensor_files, sensor_file_name, sensor_platform
from coopproc.model import FloatArray, gap_limit_s
from coopproc.sensors import ImuData

__all__ = [
    "GRAVITY_MPS2",
    "IMU_INCREMENT_COLUMNS",
    "IMU_RATE_COLUMNS",
    "IMU_RATE_LIMITS_HZ",
    "ImuData",
    "checked_imu",
    "find_imu_files",
    "frame_problem",
    "imu_platform",
    "read_imu_csv",
    "rest_gravity",
    "rest_windows",
]

IMU_RATE_COLUMNS: tuple[str, ...] = (
    "gyro_x",
    "gyro_y",
    "gyro_z",
    "accel_x",
    "accel_y",
    "accel_z",
)
IMU_INCREMENT_COLUMNS: tuple[str, ...] = (
    "dtheta_x",
    "dtheta_y",
    "dtheta_z",
    "dvel_x",
    "dvel_y",
    "dvel_z",
)
#: DATA.md: 50-1000 Hz.
IMU_RATE_LIMITS_HZ = (50.0, 1000.0)
_RATE_SLACK = 0.02
#: Standard gravity, m/s^2.
GRAVITY_MPS2 = 9.80665
#: Largest full scale of common MEMS gyros (2000 deg/s), rad/s.
_GYRO_FULL_SCALE_RADPS = 2000.0 * np.pi / 180.0
#: A unit at rest cannot turn about a horizontal axis faster than this, rad/s.
_REST_TURN_RADPS = 0.1
_HEADER = "time,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z (or dtheta_x..z, dvel_x..z)"
_NAME = sensor_file_name("imu")


def imu_platform(path: Path) -> str:
    """The platform of ``imu_<ID>.csv[.gz]``; the file's stem for any other name."""
    return sensor_platform(path, _NAME)


def find_imu_files(session_dir: Path) -> dict[str, Path]:
    """The ``imu_<ID>.csv[.gz]`` files of a session directory, by platform id (sorted)."""
    return find_sensor_files(session_dir, _NAME)


def _form(columns: list[str], where: Locator) -> tuple[Literal["rate", "increment"], list[str]]:
    """Which form the header holds, and the ignored extra columns; errors for the rest."""
    known = ("time", *IMU_RATE_COLUMNS, *IMU_INCREMENT_COLUMNS)
    rate = [c for c in IMU_RATE_COLUMNS if c in columns]
    inc = [c for c in IMU_INCREMENT_COLUMNS if c in columns]
    if rate and inc:
        raise where.error(
            f"holds rate columns ({', '.join(rate)}) and increment columns ({', '.join(inc)}); "
            "expected one form: gyro_*/accel_* or dtheta_*/dvel_*"
        )
    form: Literal["rate", "increment"] = "increment" if inc else "rate"
    wanted = ("time", *(IMU_INCREMENT_COLUMNS if inc else IMU_RATE_COLUMNS))
    extra = [c for c in columns if c not in known]
    for col in extra:
        close = difflib.get_close_matches(col, [w for w in wanted if w not in columns], 1, 0.8)
        if close:
            raise where.error(f"unknown column '{col}' (did you mean '{close[0]}'?)")
    for col in wanted:
        if col not in columns:  # a misspelling is looked for among the unknown columns
            if extra:
                raise missing_column(col, extra, where)
            raise where.error(f"missing column '{col}'; found {', '.join(columns)[:160]}")
    return form, extra


def _rate_error(where: Locator, interval: float) -> InputError | None:
    """The error for a sample rate outside DATA.md's 50..1000 Hz, with a unit hint."""
    lo, hi = IMU_RATE_LIMITS_HZ
    rate = 1.0 / interval if interval > 0 else float("inf")
    if lo * (1 - _RATE_SLACK) <= rate <= hi * (1 + _RATE_SLACK):
        return None
    found = f"samples {interval:.6g} apart (median), {rate:.4g} Hz"
    for unit, scale, divide in (("milliseconds", 1e3, "1000"), ("microseconds", 1e6, "1e6")):
        if lo <= scale / interval <= hi:
            return where.error(f"{found}: times look like {unit}; divide the times by {divide}")
    if lo <= 1e9 / interval <= hi:
        return where.error(f"{found}: times look like nanoseconds; divide the times by 1e9")
    return where.error(f"{found}; expected 50-1000 Hz (DATA.md imu_<ID>.csv)")


def rest_windows(accel: FloatArray, per_window: int) -> tuple[NDArray[np.intp], FloatArray]:
    """Indices (start) and mean accel of the 1-s windows in which the unit is at rest.

    At rest: every axis steadier than 0.2 m/s^2 (std) and the mean direction of the first
    and second half of the window within 1 deg (in the file's units: the thresholds scale
    with the median magnitude, so a file in g is judged like one in m/s^2).
    """
    n = accel.shape[0] // per_window
    if n == 0:
        return np.empty(0, dtype=np.intp), np.empty((0, 3))
    scale = float(np.median(np.linalg.norm(accel, axis=1))) / GRAVITY_MPS2 or 1.0
    win = accel[: n * per_window].reshape(n, per_window, 3)
    steady = np.all(win.std(axis=1) < 0.2 * scale, axis=1)
    half = per_window // 2
    a = win[:, :half].mean(axis=1)
    b = win[:, half:].mean(axis=1)
    cos = np.sum(a * b, axis=1) / np.maximum(
        np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300
    )
    still = steady & (cos > np.cos(np.radians(1.0)))
    return np.flatnonzero(still) * per_window, win[still].mean(axis=1).astype(np.float64)


def _check_units(
    where: Locator, gyro: FloatArray, accel: FloatArray, per_window: int, form: str
) -> tuple[float, list[str]]:
    """Unit errors (g, mg, deg/s) and notes; returns the static fraction."""
    what = "dvel / interval" if form == "increment" else "accelerations"
    mag = float(np.median(np.linalg.norm(accel, axis=1)))
    hint = "expected specific force with gravity, about 9.81 m/s^2"
    if 0.7 <= mag <= 1.4:
        raise where.error(
            f"{what} look like g (median magnitude {mag:.3f}; {hint}): multiply by 9.80665"
        )
    if 700 <= mag <= 1400:
        raise where.error(
            f"{what} look like mg (median magnitude {mag:.1f}; {hint}): multiply by 0.00980665"
        )
    if mag < 0.7:
        raise where.error(
            f"{what}: median magnitude {mag:.3g} m/s^2, as if gravity were removed; {hint}"
        )
    if not 0.5 * GRAVITY_MPS2 <= mag <= 2.0 * GRAVITY_MPS2:
        raise where.error(f"{what}: median magnitude {mag:.4g} m/s^2; {hint}")
    rates = "dtheta / interval" if form == "increment" else "gyro rates"
    deg = "look like deg/s; multiply by pi/180 = 0.0174533"
    top = float(np.quantile(np.linalg.norm(gyro, axis=1), 0.999))
    if top > _GYRO_FULL_SCALE_RADPS:
        raise where.error(
            f"{rates} up to {top:.4g} (99.9th percentile of the magnitude; above 34.9 rad/s "
            f"= 2000 deg/s, the full scale of MEMS gyros) {deg}"
        )
    starts, g_body = rest_windows(accel, per_window)
    notes: list[str] = []
    n_windows = max(accel.shape[0] // per_window, 1)
    if starts.size:
        idx = starts[:, None] + np.arange(per_window)[None, :]
        w = gyro[idx].mean(axis=1)  # mean rate per window at rest
        up = g_body / np.linalg.norm(g_body, axis=1, keepdims=True)
        horizontal = np.linalg.norm(w - np.sum(w * up, axis=1, keepdims=True) * up, axis=1)
        h = float(np.median(horizontal))
        if h > _REST_TURN_RADPS:
            raise where.error(
                f"{rates} at rest (accelerometers steady in {starts.size} 1-s windows) read "
                f"{h:.4g} about a horizontal axis: a real turn that fast would tilt gravity "
                f"by {np.degrees(h):.1f} deg per second; the values {deg}"
            )
        still = float(np.median(np.linalg.norm(w, axis=1)))
        earth_deg = np.degrees(EARTH_RATE_RADPS)
        if 0.5 * earth_deg <= still <= 2.0 * earth_deg:
            notes.append(
                f"{where.path}: at rest the gyros read {still:.3g} on average, "
                f"{still / EARTH_RATE_RADPS:.0f} x the earth rate in rad/s but close to it in "
                f"deg/s ({earth_deg:.5f}); if the file is in deg/s, convert it to rad/s"
            )
    return starts.size / n_windows, notes


def rest_gravity(imu: ImuData) -> FloatArray | None:
    """The mean specific force (body frame) over the 1-s windows at rest; None: never at rest."""
    per_window = max(round(imu.rate_hz), 2)
    starts, g_body = rest_windows(imu.accel_mps2, per_window)
    if not starts.size:
        return None
    return np.asarray(np.median(g_body, axis=0), dtype=np.float64)


def frame_problem(imu: ImuData) -> str:
    """The body-frame convention seen at rest ('' when x forward, y left, z up fits).

    At rest on the ground the specific force points up: along +z in DATA.md's body frame
    (REP 103). Along -z reads as a z-down frame (x forward, y right, z down: NED/FRD);
    along x or y as an IMU mounted on its side. Not judged for a platform whose
    session.toml gives ``imu_mounting`` (the caller's business) or that never rests.
    """
    g = rest_gravity(imu)
    if g is None:
        return ""
    up = g / np.linalg.norm(g)
    k = int(np.argmax(np.abs(up)))
    if abs(up[k]) < np.cos(np.radians(30.0)) or (k == 2 and up[2] > 0):
        return ""
    found = f"at rest the accelerometers read {np.array2string(g, precision=2)} m/s^2"
    if k == 2:
        return (
            f"{found}: gravity along -z, a z-down body frame (x forward, y right, z down: "
            "NED/FRD); expected x forward, y left, z up (REP 103): negate y and z, or set "
            "imu_mounting = [180, 0, 0]"
        )
    axis = "xyz"[k]
    return (
        f"{found}: gravity along {'+' if up[k] > 0 else '-'}{axis}; expected along +z "
        "(x forward, y left, z up, REP 103): give the IMU's mounting as imu_mounting "
        "(roll, pitch, yaw, degrees) in session.toml [platforms.<ID>]"
    )


def read_imu_csv(path: str | Path, platform: str | None = None) -> ImuData:
    """Read and validate ``imu_<ID>.csv[.gz]`` (see the module text); InputError otherwise.

    ``platform``: the id to record; default from the file name.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "no such file")
    frame, where = read_csv_table(
        path, ("time", *IMU_RATE_COLUMNS, *IMU_INCREMENT_COLUMNS), _HEADER
    )
    frame.columns = [str(c).strip() for c in frame.columns]
    form, extra = _form(list(frame.columns), where)
    names = IMU_INCREMENT_COLUMNS if form == "increment" else IMU_RATE_COLUMNS
    problems: list[InputError] = []
    time = numeric_column(frame, "time", where, problems)
    values = np.column_stack([numeric_column(frame, c, where, problems) for c in names])
    if problems:
        raise InputProblems(problems)
    where_notes = [f"{path}: columns {', '.join(extra)} ignored"] if extra else []
    return checked_imu(
        platform or imu_platform(path), where, time, values, form, tuple(where_notes)
    )


def checked_imu(
    platform: str,
    where: Locator,
    time: FloatArray,
    values: FloatArray,
    form: Literal["rate", "increment"] = "rate",
    notes: tuple[str, ...] = (),
) -> ImuData:
    """Samples (``values``: (n, 6) gyro then accel, rates or increments) checked for times,
    rate and units (see the module text) into an :class:`ImuData`; InputError otherwise."""
    path = where.path
    if time.size < 2:
        raise where.error(f"{time.size} data row(s); expected IMU samples at 50-1000 Hz")
    steps = np.diff(time)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise where.error(
            f"time {float(time[i])!r} is not after the previous sample's {float(time[i - 1])!r}; "
            "expected strictly increasing times",
            i,
            back.size,
        )
    interval = float(np.median(steps))
    err = _rate_error(where, interval)
    if err is not None:
        raise err
    if form == "increment":  # per-sample increments -> rates over the nominal interval
        values = values / interval
    gyro, accel = values[:, :3].copy(), values[:, 3:].copy()
    per_window = max(round(1.0 / interval), 2)
    static, found = _check_units(where, gyro, accel, per_window, form)
    data = ImuData(
        platform=platform,
        source=str(path),
        time_s=time,
        gyro_radps=gyro,
        accel_mps2=accel,
        form=form,
        static_fraction=static,
        notes=(*notes, *found),
    )
    gaps = data.gaps()
    if gaps:
        note = f"{path}: {gaps} gap(s) over {gap_limit_s(time):.4g} s between samples"
        data = replace(data, notes=(*data.notes, note))
    return data
