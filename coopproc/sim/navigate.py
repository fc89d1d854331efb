"""One actor's own navigation as logged: the leader's GNSS/INS or a follower's dead reckoning.

Positions, heading, 1-sigma and velocity on the full nav grid from the models of
:mod:`coopproc.sim.gnss` and :mod:`coopproc.sim.deadreckoning` (with the dead-reckoning
faults drawn when the scenario has any), the ``truth/nav_faults.csv`` rows of those
faults, the actor's session.toml platform entry, and the move of a navigation solution
into the actor's own frame. Used by :func:`coopproc.sim.engine.simulate`.
"""

from __future__ import annotations

import numpy as np

from coopproc.model import Platform
from coopproc.sim.deadreckoning import (
    DrErrors,
    course_rad,
    dead_reckon,
    dr_drift_sigma_mps,
    draw_dr_errors,
    draw_dr_faults,
)
from coopproc.sim.gnss import leader_drift_sigma_mps, leader_jitter, leader_nav
from coopproc.sim.params import SimParams
from coopproc.sim.scenarios import Actor, named_rng

__all__ = ["actor_platform", "dr_fault_rows", "heading_of", "navigate", "own_frame"]


def heading_of(enu_m: np.ndarray) -> np.ndarray:
    """The course over ground along a path, degrees clockwise from north (last repeated)."""
    _, course = course_rad(enu_m)
    return np.asarray(np.mod(np.rad2deg(np.concatenate((course, course[-1:]))), 360.0))


def own_frame(
    enu_m: np.ndarray, heading_deg: np.ndarray, shift_en: np.ndarray, rotation_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Session-frame positions/heading -> a frame where session = R_cw(rot) nav + shift."""
    a = np.deg2rad(rotation_deg)
    e, n = enu_m[:, 0] - shift_en[0], enu_m[:, 1] - shift_en[1]
    out = enu_m.copy()
    out[:, 0] = e * np.cos(a) - n * np.sin(a)
    out[:, 1] = e * np.sin(a) + n * np.cos(a)
    return out, np.mod(heading_deg - rotation_deg, 360.0)


def actor_platform(actor: Actor, params: SimParams) -> Platform:
    """The actor's session.toml platform: role, declared drift sigma, anchor position."""
    if actor.role == "anchor":
        p = actor.truth_enu_m[0]
        return Platform(actor.id, "anchor", None, (float(p[0]), float(p[1]), float(p[2])))
    if actor.role == "tag":
        return Platform(actor.id, "tag")
    drift = leader_drift_sigma_mps(params) if actor.nav == "gnss" else dr_drift_sigma_mps(params)
    return Platform(actor.id, actor.role, round(drift, 4))


def navigate(
    actor: Actor,
    heading_deg: np.ndarray,
    time_s: np.ndarray,
    params: SimParams,
    seed: int,
    *,
    drifting: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, DrErrors | None]:
    """An actor's own navigation on the full nav grid: positions, heading, 1-sigma,
    velocity (or None) and, for dead reckoning, the errors drawn (leaders: None).

    The draws of the fault-free models come first from the actor's ``nav:`` stream; the
    faults and the leader's extra noise come from streams of their own, so adding them
    leaves every earlier scenario's numbers as they were.
    """
    rng = named_rng(seed, f"nav:{actor.id}")
    truth = actor.truth_enu_m
    if actor.nav == "gnss":
        pos, head, sigma = leader_nav(truth, heading_deg, time_s, params, rng)
        if params.leader_white_m == 0 and not params.leader_velocity:
            return pos, head, sigma, None, None
        white, vel = leader_jitter(truth, time_s, params, named_rng(seed, f"nav-jitter:{actor.id}"))
        return pos + white, head, np.hypot(sigma, params.leader_white_m), vel, None
    errors = draw_dr_errors(params, rng)
    if _has_dr_faults(params):
        fault_rng = named_rng(seed, f"dr-faults:{actor.id}")
        errors = draw_dr_faults(errors, params, fault_rng, drifting=drifting)
    pos, head, sigma = dead_reckon(truth, time_s, params, errors, rng)
    return pos, head, sigma, None, errors


def _has_dr_faults(params: SimParams) -> bool:
    return bool(
        params.heading_drift_dpm > 0
        or params.odo_scale_fault[1] > 0
        or params.slip_rate_per_hour > 0
    )


def dr_fault_rows(
    pid: str, errors: DrErrors, start: float, duration: float, t_rel: np.ndarray
) -> list[list[object]]:
    """``truth/nav_faults.csv`` rows of one follower's drawn dead-reckoning faults (a
    slip only if a nav step ends inside it: one that did nothing is no fault)."""
    rows: list[list[object]] = []
    if errors.heading_drift_dpm:
        rows.append([pid, "heading_drift", start, start + duration, errors.heading_drift_dpm])
    if errors.odo_scale_fault:
        rows.append([pid, "odo_scale", start, start + duration, errors.odo_scale_fault])
    for slip in errors.slips:
        if ((t_rel[1:] > slip.start_s) & (t_rel[1:] <= slip.end_s)).any():
            rows.append([pid, "slip", start + slip.start_s, start + slip.end_s, slip.over_read])
    return rows
