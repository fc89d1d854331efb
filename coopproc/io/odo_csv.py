"""odo_<ID>.csv (plain or .csv.gz): odometer speeds, read and validated (DATA.md "Raw sensors").

Two forms, one per file: ``time, speed`` (m/s, forward; negative when reversing), or
``time, v_left, v_right`` (m/s, the two wheels of a differential drive), which needs the
platform's ``wheelbase`` (session.toml ``[platforms.<ID>]``, metres): forward speed =
(v_left + v_right) / 2, yaw rate = (v_right - v_left) / wheelbase (rad/s, counter-clockwise
positive, body z up). :func:`read_odo_csv` returns an :class:`OdometerData`.

Checked, each one line naming the file (and line) and what was found:

- a missing column (with the misspelled one when there is one), both forms in one file,
  an extra column that looks like a misspelled known one (other extra columns are
  ignored, with a note); wheel speeds without a wheelbase;
- cells that are empty, NaN, inf or text;
- times that go backwards or repeat (a duplicate time is a logging fault);
- the sample rate (1 / median interval) outside 1..1000 Hz (2 % slack), with a hint when
  the times look like milliseconds, microseconds or nanoseconds;
- speeds a ground platform cannot have (above 100 m/s = 360 km/h), with a hint when
  they look like km/h or mm/s. Speeds in km/h below that limit cannot be told from the
  file alone; :func:`odometer_scale_problem` compares the odometer's distance with the
  navigation's when the session has one (a ratio near 3.6 reads as km/h).
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Literal

import numpy as np

from coopproc.errors import InputError
from coopproc.io._common import InputProblems, Locator, missing_column, numeric_column
from coopproc.io.csv_traj import read_csv_table
from coopproc.io.file_names import find_sensor_files, sensor_file_name, sensor_platform
from coopproc.model import FloatArray, gap_limit_s
from coopproc.sensors import OdometerData

__all__ = [
    "ODO_RATE_LIMITS_HZ",
    "ODO_SPEED_COLUMNS",
    "ODO_WHEEL_COLUMNS",
    "OdometerData",
    "checked_twist",
    "find_odo_files",
    "odo_platform",
    "odometer_from_arrays",
    "odometer_scale_problem",
    "read_odo_csv",
]

ODO_SPEED_COLUMNS: tuple[str, ...] = ("speed",)
ODO_WHEEL_COLUMNS: tuple[str, ...] = ("v_left", "v_right")
#: The sample rates accepted, Hz (wheel encoders log at 1..1000 Hz).
ODO_RATE_LIMITS_HZ = (1.0, 1000.0)
#: The fastest ground platform, m/s (360 km/h).
MAX_GROUND_SPEED_MPS = 100.0
_RATE_SLACK = 0.02
_HEADER = "time,speed (or time,v_left,v_right)"
_NAME = sensor_file_name("odo")


def odo_platform(path: Path) -> str:
    """The platform of ``odo_<ID>.csv[.gz]``; the file's stem for any other name."""
    return sensor_platform(path, _NAME)


def find_odo_files(session_dir: Path) -> dict[str, Path]:
    """The ``odo_<ID>.csv[.gz]`` files of a session directory, by platform id (sorted)."""
    return find_sensor_files(session_dir, _NAME)


def _form(columns: list[str], where: Locator) -> tuple[Literal["speed", "wheels"], list[str]]:
    known = ("time", *ODO_SPEED_COLUMNS, *ODO_WHEEL_COLUMNS)
    wheels = [c for c in ODO_WHEEL_COLUMNS if c in columns]
    if wheels and "speed" in columns:
        raise where.error(
            f"holds speed and wheel speeds ({', '.join(wheels)}); "
            "expected one form: speed, or v_left and v_right"
        )
    form: Literal["speed", "wheels"] = "wheels" if wheels else "speed"
    wanted = ("time", *(ODO_WHEEL_COLUMNS if wheels else ODO_SPEED_COLUMNS))
    extra = [c for c in columns if c not in known]
    for col in extra:
        close = difflib.get_close_matches(col, [w for w in wanted if w not in columns], 1, 0.7)
        if close:
            raise where.error(f"unknown column '{col}' (did you mean '{close[0]}'?)")
    for col in wanted:
        if col not in columns:
            if extra:
                raise missing_column(col, extra, where)
            raise where.error(f"missing column '{col}'; found {', '.join(columns)[:160]}")
    return form, extra


def _check_times(time: FloatArray, where: Locator) -> float:
    """Strictly increasing times at 1..1000 Hz; returns the median interval."""
    steps = np.diff(time)
    same = np.flatnonzero(steps == 0)
    back = np.flatnonzero(steps < 0)
    if back.size and (not same.size or back[0] < same[0]):
        i = int(back[0]) + 1
        raise where.error(
            f"time {float(time[i])!r} is before the previous sample's {float(time[i - 1])!r}; "
            "expected increasing times",
            i,
            back.size,
        )
    if same.size:
        i = int(same[0]) + 1
        raise where.error(
            f"time {float(time[i])!r} repeats the previous sample's; expected one sample per time",
            i,
            same.size,
        )
    interval = float(np.median(steps))
    lo, hi = ODO_RATE_LIMITS_HZ
    rate = 1.0 / interval
    if lo * (1 - _RATE_SLACK) <= rate <= hi * (1 + _RATE_SLACK):
        return interval
    found = f"samples {interval:.6g} apart (median), {rate:.4g} Hz"
    for unit, scale, divide in (
        ("milliseconds", 1e3, "1000"),
        ("microseconds", 1e6, "1e6"),
        ("nanoseconds", 1e9, "1e9"),
    ):
        if lo <= scale / interval <= hi:
            raise where.error(f"{found}: times look like {unit}; divide the times by {divide}")
    raise where.error(f"{found}; expected 1-1000 Hz (DATA.md odo_<ID>.csv)")


def _check_speeds(names: tuple[str, ...], values: FloatArray, where: Locator) -> None:
    for k, name in enumerate(names):
        speed = np.abs(values[:, k])
        fast = np.flatnonzero(speed > MAX_GROUND_SPEED_MPS)
        if not fast.size:
            continue
        top = float(speed.max())
        hint = "; expected m/s"
        if top / 3.6 <= MAX_GROUND_SPEED_MPS:
            hint = ": look like km/h; divide by 3.6"
        elif top / 1000.0 <= MAX_GROUND_SPEED_MPS:
            hint = ": look like mm/s; divide by 1000"
        raise where.error(
            f"column '{name}': {float(values[fast[0], k]):.6g} m/s, faster than a ground "
            f"platform (> 100 m/s = 360 km/h){hint}",
            int(fast[0]),
            fast.size,
        )


def read_odo_csv(
    path: str | Path, platform: str | None = None, wheelbase_m: float | None = None
) -> OdometerData:
    """Read and validate ``odo_<ID>.csv[.gz]`` (see the module text); InputError otherwise.

    ``platform``: the id to record (default from the file name); ``wheelbase_m``: the
    platform's wheelbase, needed by the ``v_left, v_right`` form.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "no such file")
    frame, where = read_csv_table(path, ("time", *ODO_SPEED_COLUMNS, *ODO_WHEEL_COLUMNS), _HEADER)
    frame.columns = [str(c).strip() for c in frame.columns]
    form, extra = _form(list(frame.columns), where)
    pid = platform or odo_platform(path)
    if form == "wheels" and wheelbase_m is None:
        raise where.error(
            f"v_left, v_right need the wheelbase: set wheelbase (m) in session.toml "
            f"[platforms.{pid}]"
        )
    names = ODO_WHEEL_COLUMNS if form == "wheels" else ODO_SPEED_COLUMNS
    problems: list[InputError] = []
    time = numeric_column(frame, "time", where, problems)
    values = np.column_stack([numeric_column(frame, c, where, problems) for c in names])
    if problems:
        raise InputProblems(problems)
    if time.size < 2:
        raise where.error(f"{time.size} data row(s); expected odometer samples at 1-1000 Hz")
    _check_times(time, where)
    _check_speeds(names, values, where)
    notes = [f"{path}: columns {', '.join(extra)} ignored"] if extra else []
    data = odometer_from_arrays(pid, str(path), time, values, wheelbase_m, tuple(notes))
    if data.gaps():
        note = f"{path}: {data.gaps()} gap(s) over {gap_limit_s(time):.4g} s between samples"
        data = OdometerData(**{**data.__dict__, "notes": (*data.notes, note)})
    return data


def checked_twist(
    platform: str,
    where: Locator,
    time: FloatArray,
    speed: FloatArray,
    yaw_rate: FloatArray | None = None,
) -> OdometerData:
    """A ``nav_msgs/msg/Odometry`` twist (``linear.x`` forward speed, ``angular.z`` yaw
    rate) checked like ``odo_<ID>.csv`` (finite, times, rate, speeds) into OdometerData."""
    values = np.column_stack([time, speed] + ([] if yaw_rate is None else [yaw_rate]))
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise where.error(
            "NaN or inf time or twist; expected finite numbers", int(bad[0]), bad.size
        )
    if time.size < 2:
        raise where.error(f"{time.size} message(s); expected odometry at 1-1000 Hz")
    _check_times(time, where)
    _check_speeds(("twist.twist.linear.x",), speed[:, None], where)
    return OdometerData(
        platform,
        where.path,
        time,
        np.asarray(speed, dtype=np.float64),
        "twist" if yaw_rate is not None else "speed",
        yaw_rate_radps=None if yaw_rate is None else np.asarray(yaw_rate, dtype=np.float64),
    )


def odometer_from_arrays(
    platform: str,
    source: str,
    time_s: FloatArray,
    values: FloatArray,
    wheelbase_m: float | None = None,
    notes: tuple[str, ...] = (),
) -> OdometerData:
    """OdometerData from (n, 1) speeds or (n, 2) wheel speeds (left, right)."""
    values = np.asarray(values, dtype=np.float64).reshape(len(time_s), -1)
    if values.shape[1] == 1:
        return OdometerData(platform, source, time_s, values[:, 0].copy(), "speed", notes=notes)
    if wheelbase_m is None:
        raise ValueError("wheel speeds need a wheelbase")
    left, right = values[:, 0], values[:, 1]
    return OdometerData(
        platform,
        source,
        time_s,
        0.5 * (left + right),
        "wheels",
        yaw_rate_radps=(right - left) / wheelbase_m,
        wheelbase_m=wheelbase_m,
        notes=notes,
    )


def odometer_scale_problem(odo: OdometerData, nav_time_s: FloatArray, nav_en_m: FloatArray) -> str:
    """A km/h look seen against the navigation over the common span ('' when none).

    The odometer's distance over the navigation's path length (the navigation taken once
    a second, so that its noise adds little; both over >= 10 s and >= 20 m): 3.0..4.3
    reads as km/h. Other ratios are not judged: a navigation's noise lengthens its path,
    wheels slip, and a platform standing still has an odometer reading zero.
    """
    lo = max(float(odo.time_s[0]), float(nav_time_s[0]))
    hi = min(float(odo.time_s[-1]), float(nav_time_s[-1]))
    if hi - lo < 10.0:
        return ""
    grid = np.arange(lo, hi, 1.0)
    east = np.interp(grid, nav_time_s, nav_en_m[:, 0])
    north = np.interp(grid, nav_time_s, nav_en_m[:, 1])
    path_m = float(np.sum(np.hypot(np.diff(east), np.diff(north))))
    keep = (odo.time_s >= lo) & (odo.time_s <= hi)
    s, t = np.abs(odo.speed_mps[keep]), odo.time_s[keep]
    odo_m = float(np.sum(0.5 * (s[1:] + s[:-1]) * np.diff(t)))
    if path_m < 20.0:
        return ""
    ratio = odo_m / path_m
    if 3.0 <= ratio <= 4.3:
        return (
            f"odometer distance {odo_m:.1f} m is {ratio:.2f} x the navigation's {path_m:.1f} m "
            "over the same time: speeds look like km/h; divide by 3.6"
        )
    return ""
