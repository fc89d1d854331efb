"""Write a Session as a session directory that ``read_session`` reads back to it.

``session.toml`` (with the origin actually used, so geodetic files convert back to the
same ENU), ``nav_<ID>.csv``, ``ranges.csv``, and references as ``ref_<ID>.pos`` (RTKLIB,
geodetic, GPST calendar times, Q from ``Trajectory.quality``, sd columns from sigma) or
``ref_<ID>.csv`` (ENU, with a ``quality`` column when there is one).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np

from coopproc import timeconv
from coopproc.errors import OutputError
from coopproc.frames import enu2geodetic
from coopproc.io.csv_traj import write_traj_csv
from coopproc.io.ranges_csv import write_ranges_csv
from coopproc.io.raw_sensors import write_imu_csv, write_odo_csv
from coopproc.io.rtklib_pos import write_pos
from coopproc.io.session_toml import write_session_toml
from coopproc.model import Session, SessionConfig, Trajectory

__all__ = ["session_to_gpst", "write_reference_pos", "write_session"]


def session_to_gpst(time_s: np.ndarray, config: SessionConfig) -> np.ndarray:
    """GPST seconds since the GPS epoch of session times (needs gps_tow + week, or unix)."""
    if config.time_base == "gps_tow":
        if config.gps_week is None:
            raise OutputError(
                "writing RTKLIB .pos in the gps_tow time base needs [time] gps_week; "
                "set it or write the reference as CSV"
            )
        return timeconv.week_tow_to_gpst(config.gps_week, time_s)
    if config.time_base == "unix":
        return timeconv.unix_to_gpst(time_s)
    raise OutputError(
        "a relative time base cannot be written as RTKLIB .pos (absolute GPS times); "
        "write the reference as CSV"
    )


def write_reference_pos(
    traj: Trajectory,
    path: str | Path,
    config: SessionConfig,
    origin_llh: tuple[float, float, float],
    **options: object,
) -> Path:
    """Write one reference trajectory as an RTKLIB .pos file (see ``write_pos`` options)."""
    gpst = session_to_gpst(traj.time_s, config)
    llh = enu2geodetic(traj.enu_m, origin_llh)
    return write_pos(
        path,
        gpst,
        llh,
        quality=traj.quality,
        sigma_enu_m=traj.sigma_enu_m,
        **options,  # type: ignore[arg-type]
    )


def write_session(
    session: Session,
    directory: str | Path,
    *,
    reference_format: Literal["pos", "csv"] = "pos",
    compress: bool = False,
) -> list[Path]:
    """Write ``session`` into ``directory`` (created if needed); returns the files written."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    if reference_format not in ("pos", "csv"):
        raise OutputError(f"reference_format {reference_format!r}; expected 'pos' or 'csv'")
    ext = ".csv.gz" if compress else ".csv"
    config = replace(session.config, platforms=dict(session.platforms))
    written = [write_session_toml(config, out / "session.toml", session.origin_llh)]
    for pid in sorted(session.nav):
        written.append(write_traj_csv(session.nav[pid], out / f"nav_{pid}{ext}"))
    written.append(write_ranges_csv(session.ranges, out / f"ranges{ext}"))
    for pid in sorted(session.reference):
        traj = session.reference[pid]
        if reference_format == "pos":
            written.append(
                write_reference_pos(
                    traj, out / f"ref_{pid}.pos", session.config, session.origin_llh
                )
            )
        else:
            written.append(write_traj_csv(traj, out / f"ref_{pid}{ext}"))
    for pid in sorted(session.imu):  # raw sensors (DATA.md), when the session has them
        written.append(write_imu_csv(session.imu[pid], out / f"imu_{pid}{ext}"))
    for pid in sorted(session.odometer):
        written.append(write_odo_csv(session.odometer[pid], out / f"odo_{pid}{ext}"))
    return written
