"""``coopproc report OUT --stochastic``: the UWB range residual analysis of a finished run
and the Allan deviation of its session's IMU files, computed and written into OUT.

The glue between the readers (:mod:`coopproc.io.imu_csv`) and the reporters
(:mod:`coopproc.report.stochastic`, :mod:`coopproc.report.allan`): the IMU files are
the ``imu_<ID>.csv[.gz]`` of the session directory that run.json names
(``info["session"]["path"]``, resolved against the current directory when relative, as
``coopproc run`` recorded it), or the files given explicitly. Writes (each atomically)
``OUT/stochastic.csv``, ``OUT/allan.csv`` (with IMU data) and, when asked,
``OUT/figures/uwb_acf``, ``uwb_pdf``, ``allan``.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import CoopprocError, InputError, OutputError
from coopproc.io.assemble import choose_origin, to_session_time, to_trajectory
from coopproc.io.csv_mapping import CsvForms
from coopproc.io.imu_csv import find_imu_files, imu_platform, read_imu_csv, rest_windows
from coopproc.io.outdir import check_output_file, csv_text, write_text_atomic
from coopproc.io.registry import find_files, read_trajectory
from coopproc.io.session_toml import read_session_toml
from coopproc.model import FloatArray, SessionConfig
from coopproc.report.allan import (
    ALLAN_COLUMNS,
    DEFAULT_TAU_S,
    REST_NOISE_FACTOR,
    REST_SPEED_MPS,
    REST_TURN_RADPS,
    ImuAllan,
    allan_frame,
    imu_allan,
)
from coopproc.report.pages import FigureOptions
from coopproc.report.run_tables import RunTables
from coopproc.report.stochastic import (
    MIN_EPOCHS,
    STOCHASTIC_COLUMNS,
    StochasticReport,
    stochastic_frame,
    uwb_stochastics,
)
from coopproc.report.stochastic_figures import render_stochastic_figures

__all__ = [
    "imu_sources",
    "rest_mask",
    "stochastic_report",
    "track_speed",
    "window_times",
    "write_stochastic",
]


def imu_sources(info: Mapping[str, Any]) -> tuple[dict[str, Path], list[str]]:
    """The session's IMU files by platform (from run.json's session path), and notes."""
    session = info.get("session")
    raw = session.get("path") if isinstance(session, Mapping) else None
    if not raw:
        return {}, ["run.json names no session path: no IMU files looked for (use --imu FILE)"]
    path = Path(str(raw))
    if path.is_file():
        return {}, [
            f"session {path} is one file (MCAP): its IMU messages are not read by this "
            "version; give imu_<ID>.csv with --imu FILE"
        ]
    if not path.is_dir():
        where = "" if path.is_absolute() else f" (relative to {Path.cwd()})"
        return {}, [
            f"session directory {path} of run.json not found{where}: no IMU files looked "
            "for; run from where coopproc run ran, or give them with --imu FILE"
        ]
    found = find_imu_files(path)
    if not found:
        return {}, [f"no imu_<ID>.csv in the session {path}: no Allan deviation"]
    return found, []


def rest_mask(
    time_s: FloatArray,
    gyro_radps: FloatArray,
    accel_mps2: FloatArray,
    speed_mps: FloatArray | None = None,
) -> NDArray[np.bool_]:
    """The samples in 1-s windows at rest (see the module text).

    ``speed_mps``: the navigation's speed across each 1-s window (NaN where it does not
    cover the window: not at rest); None when the session has no track to judge by.
    """
    n = time_s.size
    rate = 1.0 / float(np.median(np.diff(time_s))) if n > 1 else 1.0
    per_window = max(round(rate), 2)
    windows = n // per_window
    still = np.zeros(windows, dtype=bool)
    starts, _ = rest_windows(accel_mps2, per_window)
    still[starts // per_window] = True
    if still.any():
        g = gyro_radps[: windows * per_window].reshape(windows, per_window, 3)
        mean, std = g.mean(axis=1), g.std(axis=1)
        centre = np.median(mean[still], axis=0)
        noise = np.median(std[still], axis=0)
        turning = np.linalg.norm(mean - centre, axis=1) > REST_TURN_RADPS
        shaking = np.any(std > REST_NOISE_FACTOR * noise + 1e-12, axis=1)
        still &= ~turning & ~shaking
    if speed_mps is not None:
        with np.errstate(invalid="ignore"):
            still &= np.asarray(speed_mps[:windows]) < REST_SPEED_MPS
    out = np.zeros(n, dtype=bool)
    out[: windows * per_window] = np.repeat(still, per_window)
    return out


def window_times(time_s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Start and end time of each 1-s window of :func:`rest_mask`."""
    rate = 1.0 / float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    per_window = max(round(rate), 2)
    windows = time_s.size // per_window
    edges = time_s[: windows * per_window].reshape(windows, per_window)
    return edges[:, 0].copy(), edges[:, -1].copy()


def _session_dir(info: Mapping[str, Any]) -> Path | None:
    session = info.get("session")
    raw = session.get("path") if isinstance(session, Mapping) else None
    path = Path(str(raw)) if raw else None
    return path if path is not None and path.is_dir() else None


def track_speed(
    info: Mapping[str, Any], platform: str, imu_time_s: FloatArray
) -> tuple[FloatArray | None, str | None]:
    """The speed of ``platform``'s navigation (else reference) across each 1-s window of
    :func:`coopproc.report.allan.rest_mask`, m/s (NaN outside the track), and the file
    it came from; (None, None) when the session has no track over the IMU's times.

    The file is read alone (the session's ``[files]``, ``[columns]`` and time base
    apply), not the whole session: the report needs one track.
    """
    root = _session_dir(info)
    if root is None:
        return None, None
    try:
        toml = (
            read_session_toml(root / "session.toml") if (root / "session.toml").is_file() else None
        )
        config = toml.config if toml else SessionConfig()
        forms = toml.forms if toml else CsvForms()
        files = find_files(root, config)
        for kind, group in (("nav", files.nav), ("ref", files.ref)):
            path = group.get(platform)
            if path is None:
                continue
            raw = read_trajectory(path, platform, forms.form(f"{kind}.{platform}"))
            if raw.time_kind != "session":
                if config.gps_week is None and config.time_base == "gps_tow":
                    continue
                raw = to_session_time(raw, config.time_base, config.gps_week)
            origin, _ = choose_origin(config, {}, {platform: raw})
            traj = to_trajectory(raw, origin)
            start, end = window_times(imu_time_s)
            inside = (start >= traj.time_s[0]) & (end <= traj.time_s[-1])
            if not inside.any():
                continue
            a, b = traj.interpolate(start), traj.interpolate(end)
            with np.errstate(invalid="ignore", divide="ignore"):
                speed = np.linalg.norm(b - a, axis=1) / np.maximum(end - start, 1e-9)
            return np.where(inside, speed, np.nan), path.name
    except CoopprocError:
        return None, None  # a track that does not read: the IMU alone judges
    return None, None


def stochastic_report(
    out_dir: str | Path,
    run: RunTables,
    imu_files: Sequence[str | Path] = (),
    *,
    allan_tau_s: float = DEFAULT_TAU_S,
) -> StochasticReport:
    """The UWB analysis of ``run`` and the Allan deviation of the IMU files: ``imu_files``
    when given, else the session's. InputError when there is nothing to analyse, or when
    an IMU is not at rest long enough for ``allan_tau_s`` (report/allan.py)."""
    pairs, notes = uwb_stochastics(run.ranges)
    if imu_files:
        files: dict[str, Path] = {}
        for f in map(Path, imu_files):
            first = files.setdefault(imu_platform(f), f)
            if first != f:
                raise InputError(
                    f, f"second IMU file for platform {imu_platform(f)} (first: {first}); give one"
                )
    else:
        files, more = imu_sources(run.info)
        notes += more
    results: list[ImuAllan] = []
    for platform, path in files.items():
        imu = read_imu_csv(path, platform)
        speed, track = track_speed(run.info, platform, imu.time_s)
        rest = rest_mask(imu.time_s, imu.gyro_radps, imu.accel_mps2, speed)
        judged = "the IMU" if track is None else f"the IMU and the speed of {track}"
        res = imu_allan(
            platform,
            str(path),
            imu.time_s,
            imu.gyro_radps,
            imu.accel_mps2,
            rest,
            tau_s=allan_tau_s,
            judged=judged,
        )
        notes += [*imu.notes, *res.notes]
        results.append(res)
    if not pairs and not results:
        raise InputError(
            Path(out_dir) / "ranges.csv",
            f"no pair has {MIN_EPOCHS} line-of-sight epochs with a reference distance, and "
            "no IMU file was found: nothing for the stochastic analysis (it needs the "
            "reference, ref_<ID> files, or --imu FILE)",
        )
    return StochasticReport(tuple(pairs), tuple(results), tuple(notes))


def _csv_text(frame: Any, columns: Sequence[str]) -> str:
    return csv_text(frame[list(columns)])


def _write_bytes_atomic(path: Path, data: bytes) -> Path:
    """``data`` to ``path`` through a temporary file renamed into place."""
    check_output_file(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with open(fd, "wb") as handle:
                handle.write(data)
            os.chmod(tmp, 0o644)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as err:
        left = "the existing file is unchanged" if path.exists() else "nothing was written"
        raise OutputError(f"{path}: cannot write ({err.strerror or err}); {left}") from err
    return path


def write_stochastic(
    out_dir: str | Path,
    report: StochasticReport,
    *,
    formats: Sequence[str] = (),
    dpi: int = 300,
    options: FigureOptions | None = None,
) -> list[Path]:
    """Write ``stochastic.csv``, ``allan.csv`` and (``formats``) the figures into OUT;
    the tables cover every pair and platform, the figures those ``options`` keep."""
    out = Path(out_dir)
    written = []
    if report.uwb:
        text = _csv_text(stochastic_frame(report.uwb), STOCHASTIC_COLUMNS)
        written.append(write_text_atomic(out / "stochastic.csv", text))
    if report.imu:
        text = _csv_text(allan_frame(report.imu), ALLAN_COLUMNS)
        written.append(write_text_atomic(out / "allan.csv", text))
    if formats:
        figures = render_stochastic_figures(report, formats=formats, dpi=dpi, options=options)
        if figures:
            try:
                (out / "figures").mkdir(exist_ok=True)
            except OSError as err:
                raise OutputError(f"{out / 'figures'}: cannot create ({err.strerror})") from err
        for name, data in figures.items():
            written.append(_write_bytes_atomic(out / "figures" / name, data))
    return written
