"""From a session to the INS engine's inputs: aiding, start and alignment of one platform
(the INS position methods, :mod:`coopproc.stages.ins.ins_stage`; docs/methods-ins.md,
"In the pipeline").

- **Ranges**: the platform's UWB ranges to anchors (tightly coupled, with the UWB lever
  arm ``[platforms.X] uwb_lever_arm``); ranges to moving platforms are left to the
  cooperative fusion (their positions are estimates, correlated with this platform's).
- **Odometer and NHC** (``nhc=True``): the odometer's forward speed when the platform has
  one, and the non-holonomic constraints unless the session says ``nhc = false``.
- **Start**: the position of the first robust least-squares fix (paper 003 sec. 2.2) at
  or after the first IMU sample (2D), its height from the platform's own navigation (else
  ``[ins] tag_up_m``, default 0, within the start's 1-sigma); without a fix (no epoch
  with ranges to three anchors: anchors ranged one at a time) and without navigation,
  the range-by-range EKF + RTS track of its ranges (``range_rts``, 3-D: position,
  velocity and the heading of its first motion); without UWB (dead reckoning) the
  navigation file's first epoch. No start is refused without saying what would give one.
- **Alignment**: from a static start of at least 5 s, levelling (paper 003 eq. (1)-(5))
  and the heading of the navigation file, else of the first motion of the fixes; in
  motion from the first sample, levelling from the mean specific force of the first
  second (its error is the acceleration over g: about 1 deg for 0.2 m/s^2) with the
  configured sigmas. A heading from the first motion alone (no navigation heading, no
  gyrocompassing) is marked ``search``: the INS stage searches it on the ranges
  (:mod:`coopproc.ins.startup`), which also refines the position, velocity and level.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.ins.align import Alignment, coarse_align, heading_from_motion, level, static_start
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.sensors import ImuData
from coopproc.stages.shared.data import anchor_positions, range_sigma_default
from coopproc.stages.shared.lsq import LsqParams, robust_lsq_positions

__all__ = ["InsStart", "anchor_ranges", "ins_start", "odometer_scale"]

#: Static seconds at the start that allow levelling at rest (coopproc.ins.align).
MIN_STATIC_S = 5.0


@dataclass(frozen=True)
class InsStart:
    """Where and how the INS of one platform starts."""

    alignment: Alignment
    enu_m: FloatArray
    vel_enu_mps: FloatArray
    #: what the start was taken from, for the notes
    how: str
    #: the heading is a guess from the first motion (no navigation heading, no
    #: gyrocompassing): the INS stage searches it (coopproc.ins.startup)
    search: bool = False


def anchor_ranges(
    session: Session, platform: str, ranges: pd.DataFrame, fallback_sigma_m: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The platform's ranges to anchors in time order: time (n,), anchor ENU (n, 3),
    range (n,), sigma (n,) (missing sigmas: session.toml [uwb] sigma, else the fallback)."""
    anchors = anchor_positions(session)
    frame = ranges[["time", "from", "to", "range", "sigma"]]
    first = frame["from"].astype(str)
    second = frame["to"].astype(str)
    names = second.where(first == platform, first.where(second == platform, ""))
    names = names.reset_index(drop=True)
    keep = names.isin(list(anchors)).to_numpy() & np.isfinite(frame["range"].to_numpy(float))
    t = frame["time"].to_numpy(np.float64)[keep]
    order = np.argsort(t, kind="stable")
    point = np.array([anchors[str(a)] for a in names[keep]], dtype=np.float64).reshape(-1, 3)
    rng = frame["range"].to_numpy(np.float64)[keep]
    sigma = frame["sigma"].to_numpy(np.float64)[keep]
    sigma = np.where(
        np.isfinite(sigma) & (sigma > 0), sigma, range_sigma_default(session, fallback_sigma_m)
    )
    return t[order], point[order], rng[order], sigma[order]


def _at(traj: Trajectory, t: float) -> FloatArray:
    return np.array([np.interp(t, traj.time_s, traj.enu_m[:, i]) for i in range(3)])


def _nav_heading_yaw(nav: Trajectory | None, t: float) -> float | None:
    """Yaw (rad, counter-clockwise from east) of the navigation's heading at ``t``."""
    if nav is None or nav.heading_deg is None or not len(nav):
        return None
    h = np.unwrap(np.radians(nav.heading_deg))
    return float(np.pi / 2 - np.interp(t, nav.time_s, h))


def _velocity(traj: Trajectory, t: float, span_s: float = 1.0) -> FloatArray:
    """Mean velocity of a trajectory over (t, t + span_s) (m/s)."""
    a, b = _at(traj, t), _at(traj, min(t + span_s, float(traj.time_s[-1])))
    dt = min(span_s, float(traj.time_s[-1]) - t)
    return (b - a) / dt if dt > 0 else np.zeros(3)


def _fixes(
    session: Session, platform: str, ranges: pd.DataFrame, tag_up_m: float
) -> Trajectory | None:
    """The platform's robust least-squares fixes, 2D: with its own height, or ``tag_up_m``
    without a navigation file (3D fixes from anchors at similar heights can be kilometres off: the
    simulated tag-only session's first fixes were; the start's 1-sigma covers the
    height)."""
    fixes = robust_lsq_positions(session, ranges, LsqParams(dims=2, tag_up_m=tag_up_m))
    traj = fixes.get(platform)
    return traj if traj is not None and len(traj) >= 2 else None


def _range_track(session: Session, platform: str, ranges: pd.DataFrame) -> Trajectory | None:
    """The platform's range-by-range constant-velocity EKF + RTS track
    (:mod:`coopproc.stages.anchors.range_kf`): a start without simultaneous ranges (issue
    31: anchors ranged one at a time, about one range per anchor every 3 s)."""
    from coopproc.stages.anchors.range_kf import range_kf_positions

    traj = range_kf_positions(session, ranges, LsqParams(), smooth=True).get(platform)
    return traj if traj is not None and len(traj) >= 2 else None


def ins_start(
    session: Session,
    imu: ImuData,
    ranges: pd.DataFrame | None,
    *,
    level_sigma_deg: float,
    heading_sigma_deg: float,
    tag_up_m: float = 0.0,
) -> InsStart:
    """The start of one platform's INS (module docstring); ``ranges`` None: dead
    reckoning from the navigation file."""
    from coopproc.ins.models import imu_figures

    platform = imu.platform
    nav = session.nav.get(platform)
    figures = imu_figures(session.platforms[platform].imu)
    lat = np.radians(session.origin_llh[0])
    t0 = float(imu.time_s[0])
    source = None if ranges is None else _fixes(session, platform, ranges, tag_up_m)
    how = "first UWB least-squares fix"
    if source is None and ranges is not None and (nav is None or len(nav) < 2):
        source = _range_track(session, platform, ranges)
        how = "range-by-range EKF + RTS track (no epoch with simultaneous ranges for a fix)"
    if source is None:
        if nav is None or len(nav) < 2:
            raise StageError(
                f"INS of {platform}: no start position: no least-squares fix and no "
                "range-by-range track from its ranges to anchors (it needs ranges to "
                "anchors, at least 2 in all, or a navigation file nav_<ID>.csv)"
            )
        source, how = nav, f"navigation {nav.source or 'file'}"
    t_start = max(t0, float(source.time_s[0]))
    enu = _at(source, t_start)
    if nav is not None and len(nav) and source is not nav:
        enu[2] = _at(nav, t_start)[2]  # 2D fixes: the platform's own height
    yaw = _nav_heading_yaw(nav, t_start)
    motion = (source.time_s, source.enu_m)
    n_static = static_start(imu.time_s, imu.gyro_radps, imu.accel_mps2)
    static_s = float(imu.time_s[n_static - 1] - t0) if n_static > 1 else 0.0
    if static_s >= MIN_STATIC_S:
        al = coarse_align(
            imu.time_s, imu.gyro_radps, imu.accel_mps2, lat, figures, yaw=yaw, motion=motion
        )
        return InsStart(
            al, enu, np.zeros(3), f"{how}, aligned at rest ({static_s:.0f} s)",
            search=al.heading_source == "motion",
        )  # fmt: skip
    first = imu.time_s <= t0 + 1.0
    roll, pitch = level(imu.accel_mps2[first].mean(axis=0))
    heading_from = "navigation heading"
    search = yaw is None
    if yaw is None:
        _, yaw = heading_from_motion(*motion)
        heading_from = "first motion of the fixes"
    al = Alignment(
        roll,
        pitch,
        float(yaw),
        "given",
        float(np.radians(level_sigma_deg)),
        float(np.radians(heading_sigma_deg)),
        0,
    )
    vel = _velocity(nav if nav is not None and len(nav) >= 2 else source, t_start)
    return InsStart(
        al, enu, vel, f"{how}, aligned in motion (heading: {heading_from})", search=search
    )


def odometer_scale(
    time_s: FloatArray, speed_mps: FloatArray, track: Any, track_time_s: FloatArray
) -> float | None:
    """The odometer's scale error k (speed = (1 + k) true speed), least squares against the
    horizontal speed of an INS track (``enu_m``/``vel_enu`` at ``track_time_s``) where
    both move faster than 1 m/s; None with fewer than 50 such samples (docs/methods-ins.md,
    "In the pipeline")."""
    t = np.asarray(time_s, dtype=np.float64)
    inside = (t >= track_time_s[0]) & (t <= track_time_s[-1])
    ve = np.interp(t[inside], track_time_s, track.vel_enu[:, 0])
    vn = np.interp(t[inside], track_time_s, track.vel_enu[:, 1])
    v = np.hypot(ve, vn)
    o = np.asarray(speed_mps, dtype=np.float64)[inside]
    use = (v > 1.0) & (np.abs(o) > 1.0)
    if np.count_nonzero(use) < 50:
        return None
    return float(np.sum(np.abs(o[use]) * v[use]) / np.sum(v[use] ** 2) - 1.0)
