"""Dead-reckoning increments of the target, paper 004 eq. (3).

The target's navigation file holds dead reckoning in its own frame, shifted and rotated
by unknowns. Only quantities invariant to that shift and rotation are used: the length
Delta L of each step between filter epochs and the change Delta phi of its direction.
Angles here are mathematical (radians, counter-clockwise from east), as eq. (3) writes
``x += Delta L cos(phi)`` with x = east, y = north; outputs convert to headings
(degrees clockwise from north) with :func:`heading_deg`.
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.angles import wrap_pi
from coopproc.estimation.locate_result import DrIncrements
from coopproc.model import FloatArray, Trajectory

__all__ = [
    "dr_increments",
    "rotation_between",
]

#: A step shorter than this (m) has no direction of its own; it keeps the previous one.
STILL_M = 1e-6


def dr_increments(nav: Trajectory, time_s: FloatArray) -> DrIncrements:
    """Delta L and Delta phi of eq. (3) from the target's own-frame nav at ``time_s``.

    The nav is linearly interpolated at the epochs (which must lie within its span).
    """
    t = np.asarray(time_s, dtype=np.float64)
    east = np.interp(t, nav.time_s, nav.enu_m[:, 0])
    north = np.interp(t, nav.time_s, nav.enu_m[:, 1])
    step = np.column_stack([np.diff(east), np.diff(north)])
    delta_l = np.hypot(step[:, 0], step[:, 1])
    moving = delta_l > STILL_M
    theta = np.arctan2(step[:, 1], step[:, 0])
    if step.shape[0] and moving.any():
        # forward-fill the direction over still steps, back-fill the leading ones
        idx = np.where(moving, np.arange(step.shape[0]), -1)
        idx = np.maximum.accumulate(idx)
        idx[idx < 0] = int(np.argmax(moving))
        theta = theta[idx]
    else:
        theta = np.zeros(step.shape[0])
    delta_phi = np.zeros_like(theta)
    if theta.size > 1:
        delta_phi[1:] = wrap_pi(np.diff(theta))
    # re-accumulate so theta and delta_phi agree exactly (unwrapped)
    theta = theta[0] + np.cumsum(delta_phi) if theta.size else theta
    return DrIncrements(
        time_s=t,
        delta_l_m=delta_l,
        delta_phi_rad=delta_phi,
        theta_rad=theta,
        step_own_m=step,
    )


def rotation_between(
    steps_from_m: FloatArray, steps_to_m: FloatArray, path_m: float
) -> float | None:
    """Rotation (rad) that best maps ``steps_from`` onto ``steps_to`` over the first ``path_m``.

    Least squares over the steps (the angle of sum z_to * conj(z_from) with steps as complex
    numbers), using steps until the ``from`` path length reaches ``path_m``. ``None`` if
    there is no motion or a NaN step in that window.
    """
    z_from = steps_from_m[:, 0] + 1j * steps_from_m[:, 1]
    z_to = steps_to_m[:, 0] + 1j * steps_to_m[:, 1]
    cum = np.cumsum(np.abs(z_from))
    if cum.size == 0 or cum[-1] <= STILL_M:
        return None
    stop = int(np.searchsorted(cum, path_m)) + 1
    prod = z_to[:stop] * np.conj(z_from[:stop])
    if not np.all(np.isfinite(prod)) or abs(prod.sum()) <= 0.0:
        return None
    return float(np.angle(prod.sum()))
