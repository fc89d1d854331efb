"""Range increments of the RN-Based reference method (paper 000 ref. [2], Li et al. 2019).

Our reading of the reference method, as paper 000 describes it ("used the relative
velocity between dynamic platforms to detect and compensate for NLOS ... only estimated
NLOS once"): the range rate predicted from the two platforms' own navigation solutions,

    dD/dt = (X1 - X2) . (V1 - V2) / ||X1 - X2||,

times the interval between range epochs gives the predicted range change. Positions and
velocities are taken at the middle of the interval (second-order accurate). Velocities
come from the navigation files' ``vel_*`` columns when present, else from central
differences of the navigation positions. No DI smoothing and no cooperative solution are
involved. The distance filter, detection threshold and end rule are those of the DI
method; the NLOS magnitude is estimated once, at detection (``one_shot``).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, Trajectory

__all__ = ["columns_at", "platform_velocity", "rn_increments", "velocity_columns"]


def platform_velocity(traj: Trajectory, time_s: FloatArray) -> FloatArray:
    """Velocity (m/s, (n, 3) ENU) of one platform at ``time_s``; NaN outside its span."""
    return columns_at(traj, velocity_columns(traj), time_s)


def velocity_columns(traj: Trajectory) -> list[FloatArray]:
    """The velocity (m/s) east, north, up at the trajectory's own epochs, one contiguous
    array each: its ``vel_*`` columns, else central differences of its positions."""
    if traj.vel_enu_mps is not None:
        return [np.ascontiguousarray(traj.vel_enu_mps[:, a]) for a in range(3)]
    if len(traj) >= 2:
        return [np.gradient(traj.enu_m[:, a], traj.time_s) for a in range(3)]
    return [np.zeros(len(traj)) for _ in range(3)]


def columns_at(traj: Trajectory, columns: list[FloatArray], time_s: FloatArray) -> FloatArray:
    """(n, 3): three columns at the trajectory's epochs linearly interpolated at
    ``time_s`` (``np.interp``), NaN outside its span, as :meth:`Trajectory.interpolate`
    does with its positions."""
    t = np.asarray(time_s, dtype=np.float64)
    out = np.empty((t.shape[0], 3))
    for a in range(3):
        out[:, a] = np.interp(t, traj.time_s, columns[a])
    outside = (t < traj.time_s[0]) | (t > traj.time_s[-1])
    out[outside] = np.nan
    return out


def rn_increments(
    time_s: FloatArray,
    pos1_mid_m: FloatArray,
    pos2_mid_m: FloatArray,
    vel1_mid_mps: FloatArray,
    vel2_mid_mps: FloatArray,
) -> FloatArray:
    """Predicted range change from the relative velocity (m); NaN at the first epoch.

    ``*_mid`` arrays are (n, 3) at the middle of each interval (row k: between epochs k-1
    and k; row 0 is unused).
    """
    out = np.full(time_s.shape[0], np.nan)
    if time_s.shape[0] < 2:
        return out
    rel = pos1_mid_m[1:] - pos2_mid_m[1:]
    vrel = vel1_mid_mps[1:] - vel2_mid_mps[1:]
    dist = slant_ranges(rel)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.einsum("ij,ij->i", rel, vrel) / dist
    out[1:] = np.where(dist > 0, rate, 0.0) * np.diff(time_s)
    return out
