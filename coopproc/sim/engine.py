"""``simulate``: a scenario's world + sensors -> an in-memory Session and its Truth.

Everything is drawn from ``numpy.random.default_rng`` streams keyed by (seed, name), so
a seed gives the same session bit for bit, and all per-sample work is vectorized.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pandas as pd

from coopproc.configtools import nearest
from coopproc.errors import ConfigError
from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory
from coopproc.sim.deadreckoning import (
    DrErrors,
    course_rad,
    dead_reckon,
    dr_drift_sigma_mps,
    draw_dr_errors,
    draw_dr_faults,
)
from coopproc.sim.gnss import leader_drift_sigma_mps, leader_jitter, leader_nav, ppk_reference
from coopproc.sim.options import changed_options, check_options
from coopproc.sim.params import NavGapSpec, NlosSpec, OutageSpec, SimParams, apply_overrides
from coopproc.sim.scenarios import SCENARIOS, Actor, named_rng
from coopproc.sim.truth import (
    DR_ERROR_COLUMNS,
    DR_PARAM_COLUMNS,
    NAV_FAULT_COLUMNS,
    NAV_FRAME_COLUMNS,
    Simulation,
    Truth,
)
from coopproc.sim.uwb import range_times_rel, simulate_ranges

__all__ = ["scenario_params", "simulate"]


def scenario_params(scenario: str, **overrides: Any) -> SimParams:
    """The effective parameters of ``scenario`` with ``overrides`` applied.

    A parameter set where it can do nothing is a ConfigError
    (:func:`coopproc.sim.options.check_options`). The scenario's own NLOS events, outages
    and nav gaps move with ``duration_s`` (:func:`_rescale`); given ones stay as given.
    """
    return _resolve(scenario, overrides)[0]


def _resolve(
    scenario: str, overrides: Mapping[str, Any]
) -> tuple[SimParams, frozenset[str], tuple[str, ...]]:
    """The effective parameters, the names given (not None) and the names whose value
    differs from the scenario's."""
    base = _scenario_defaults(scenario)
    params = apply_overrides(base, overrides)
    changed = changed_options(base, params)
    check_options(scenario, params, changed)
    given = frozenset(key for key, value in overrides.items() if value is not None)
    if params.duration_s == base.duration_s:
        return params, given, changed
    span = (base.duration_s, params.duration_s, _nav_times_rel(params))
    ranging = 1.0 / params.range_rate_hz
    changes: dict[str, Any] = {}
    if "nlos_events" not in given:
        changes["nlos_events"] = _rescale(params.nlos_events, *span, ranging)
    if "outages" not in given:
        changes["outages"] = _rescale(params.outages, *span, ranging)
    if "nav_gaps" not in given:
        changes["nav_gaps"] = _rescale(params.nav_gaps, *span, 0.0)
    return dataclasses.replace(params, **changes), given, changed


@functools.cache
def _scenario_defaults(scenario: str) -> SimParams:
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario '{scenario}'{nearest(scenario, SCENARIOS)}")
    return apply_overrides(SimParams(), SCENARIOS[scenario].defaults)


_Spec = TypeVar("_Spec", NlosSpec, OutageSpec, NavGapSpec)


def _rescale(
    items: tuple[_Spec, ...],
    nominal_s: float,
    duration_s: float,
    nav_times: np.ndarray,
    min_length_s: float,
) -> tuple[_Spec, ...]:
    """A scenario's NLOS events, outages or nav gaps in a session of another length.

    Each moves to the same fraction of the session and keeps its length, ending at the
    latest 1 s before the session end (and at the last nav epoch); a nav gap that reached
    the session end still does. Dropped when it no longer fits: shorter than
    ``min_length_s`` (events and outages: one ranging period, so that every pair has a
    ranging epoch inside) or holding no nav epoch.
    """
    last = float(nav_times[-1])
    out = []
    for item in items:
        start = item.start_s * duration_s / nominal_s
        if isinstance(item, NavGapSpec) and item.end_s >= nominal_s:
            end = duration_s
        else:
            end = min(start + (item.end_s - item.start_s), duration_s - 1.0, last)
        holds = bool(((nav_times >= start - 1e-9) & (nav_times <= end + 1e-9)).any())
        if end > start and end - start >= min_length_s and holds:
            out.append(dataclasses.replace(item, start_s=start, end_s=end))
    return tuple(out)


def _nav_times_rel(params: SimParams) -> np.ndarray:
    """The nav-rate time grid of a session, seconds from its start (the truth's too)."""
    dt = 1.0 / params.nav_rate_hz
    return np.round(dt * np.arange(int(np.floor(params.duration_s / dt + 1e-9)) + 1), 9)


def _random_events(params: SimParams, pairs: list[str], seed: int) -> list[NlosSpec]:
    """Random NLOS events: Poisson count per pair, 10-30 s long, means 0.4-0.6 m."""
    rate = params.random_nlos_per_pair_hour
    if rate <= 0 or params.duration_s < 120.0:
        return []
    rng = named_rng(seed, "random-nlos")
    events: list[NlosSpec] = []
    for pair in pairs:
        taken = [(e.start_s, e.end_s) for e in params.nlos_events if e.pair == pair]
        for _ in range(int(rng.poisson(rate * params.duration_s / 3600.0))):
            start = float(rng.uniform(30.0, params.duration_s - 60.0))
            end = start + float(rng.uniform(10.0, 30.0))
            mean = float(rng.uniform(0.4, 0.6))
            if all(end < s - 5.0 or start > e + 5.0 for s, e in taken):
                taken.append((start, end))
                events.append(NlosSpec(pair, round(start, 1), round(end, 1), round(mean, 3)))
    return events


def _heading_deg(enu_m: np.ndarray) -> np.ndarray:
    _, course = course_rad(enu_m)
    return np.asarray(np.mod(np.rad2deg(np.concatenate((course, course[-1:]))), 360.0))


def _own_frame(
    enu_m: np.ndarray, heading_deg: np.ndarray, shift_en: np.ndarray, rotation_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Session-frame positions/heading -> a frame where session = R_cw(rot) nav + shift."""
    a = np.deg2rad(rotation_deg)
    e, n = enu_m[:, 0] - shift_en[0], enu_m[:, 1] - shift_en[1]
    out = enu_m.copy()
    out[:, 0] = e * np.cos(a) - n * np.sin(a)
    out[:, 1] = e * np.sin(a) + n * np.cos(a)
    return out, np.mod(heading_deg - rotation_deg, 360.0)


def simulate(
    scenario: str,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    platforms: int | None = None,
    **overrides: Any,
) -> Simulation:
    """Simulate ``scenario`` (a key of :data:`SCENARIOS`) with known truth.

    ``duration_s``, ``platforms`` and any other :class:`SimParams` field override the
    scenario's defaults; unknown names raise ConfigError.
    """
    params, given, changed = _resolve(
        scenario, {"duration_s": duration_s, "platforms": platforms, **overrides}
    )
    t_rel = _nav_times_rel(params)
    world = SCENARIOS[scenario].build(params, seed, t_rel)
    start = params.start_tow_s
    time = start + t_rel

    truth_traj: dict[str, Trajectory] = {}
    nav: dict[str, Trajectory] = {}
    reference: dict[str, Trajectory] = {}
    plats: dict[str, Platform] = {}
    dr_err_frames, dr_param_rows, frame_rows = [], [], []
    ref_dt = 1.0 / params.ref_rate_hz
    every = max(1, round(params.nav_rate_hz))
    t_ref = start + np.round(
        ref_dt * np.arange(int(np.floor(params.duration_s / ref_dt + 1e-9)) + 1), 9
    )
    _check_gaps(params, world.actors, t_rel)
    fault_rows: list[list[object]] = []
    # the heading-rate fault goes to the first dead-reckoning platform in sorted order
    drifting = min((a.id for a in world.actors if a.nav == "dr"), default=None)
    for actor in sorted(world.actors, key=lambda a: a.id):
        heading = _heading_deg(actor.truth_enu_m)
        truth = Trajectory(actor.id, time, actor.truth_enu_m, heading_deg=heading, source="truth")
        truth_traj[actor.id] = truth
        plats[actor.id] = _platform(actor, params)
        if actor.nav == "none":
            continue
        pos, head, sigma, vel, errors = _navigate(
            actor, heading, time, params, seed, drifting=actor.id == drifting
        )
        if errors is not None:
            fault_rows += _fault_rows(actor.id, errors, start, params.duration_s, t_rel)
            dr_param_rows.append(
                [
                    actor.id,
                    errors.gyro_bias_dph,
                    errors.odo_scale,
                    errors.heading_init_deg,
                    *errors.init_error_m,
                ]
            )
        logged = _logged(t_rel, params.nav_gaps, actor.id)
        for gap in (g for g in params.nav_gaps if g.platform == actor.id):
            removed = int((~_logged(t_rel, (gap,), actor.id)).sum())
            fault_rows.append(
                [actor.id, "nav_gap", start + gap.start_s, start + gap.end_s, float(removed)]
            )
        # DR error at whole seconds of the nav grid (a compact truth file), where logged
        whole = np.zeros(time.shape[0], dtype=bool)
        whole[::every] = True
        whole &= logged
        err = (pos - actor.truth_enu_m)[whole]
        dr_err_frames.append(
            pd.DataFrame(
                {
                    "time": time[whole],
                    "platform": actor.id,
                    "error_east": err[:, 0],
                    "error_north": err[:, 1],
                    "error_up": err[:, 2],
                    "error_h": np.hypot(err[:, 0], err[:, 1]),
                }
            )
        )
        if actor.own_frame:
            shift = actor.truth_enu_m[0, :2]
            rotation = float(heading[0])
            pos, head = _own_frame(pos, head, shift, rotation)
            frame_rows.append([actor.id, rotation, float(shift[0]), float(shift[1])])
        nav[actor.id] = Trajectory(
            actor.id,
            time[logged],
            pos[logged],
            sigma_enu_m=sigma[logged],
            heading_deg=head[logged],
            vel_enu_mps=None if vel is None else vel[logged],
            source="simulated",
        )
        ref_pos, ref_sigma, quality = ppk_reference(
            truth.interpolate(t_ref), t_ref, params, named_rng(seed, f"ref:{actor.id}")
        )
        reference[actor.id] = Trajectory(
            actor.id, t_ref, ref_pos, sigma_enu_m=ref_sigma, quality=quality, source="simulated"
        )

    pairs = sorted(link.pair for link in world.links)
    events = [*params.nlos_events, *_random_events(params, pairs, seed)]
    unknown = sorted({e.pair for e in events} - set(pairs))
    if unknown:
        raise ConfigError(
            f"NLOS events on pairs without ranging: {', '.join(unknown)} "
            f"(pairs: {', '.join(pairs)})"
        )
    _check_epochs(params, given, range_times_rel(truth_traj, world.links, params, start), t_rel)
    if not events and "nlos_sigma_m" in changed:
        raise ConfigError(
            "simulation parameter 'nlos_sigma_m' does nothing in a session without NLOS "
            "events (set nlos_events or random_nlos_per_pair_hour)"
        )
    outages: Sequence[OutageSpec] = params.outages
    if params.exact_ranges:
        events, outages = [], ()
    out = simulate_ranges(truth_traj, world.links, params, events, outages, start, seed)

    config = SessionConfig(
        name=f"{scenario} seed {seed}",
        time_base="gps_tow",
        gps_week=params.gps_week,
        origin_llh=params.origin_llh,
        platforms=plats,
        uwb_sigma_m=params.uwb_declared_sigma_m,
        reference_quality=(1,),
    )
    session = Session(
        config=config,
        platforms=plats,
        nav=nav,
        reference=reference,
        ranges=RangeTable(out.ranges, source="simulated"),
        origin_llh=params.origin_llh,
        root=Path(scenario),
    )
    truth_obj = Truth(
        trajectories=truth_traj,
        distances=out.distances,
        nlos_events=out.nlos_events,
        gross_errors=out.gross_errors,
        dr_error=pd.concat(dr_err_frames, ignore_index=True)
        if dr_err_frames
        else pd.DataFrame(columns=list(DR_ERROR_COLUMNS)),
        dr_params=pd.DataFrame(dr_param_rows, columns=list(DR_PARAM_COLUMNS)),
        nav_frames=pd.DataFrame(frame_rows, columns=list(NAV_FRAME_COLUMNS)),
        params=params,
        nav_faults=pd.DataFrame(fault_rows, columns=list(NAV_FAULT_COLUMNS)),
    )
    return Simulation(scenario=scenario, seed=seed, session=session, truth=truth_obj)


def _platform(actor: Actor, params: SimParams) -> Platform:
    if actor.role == "anchor":
        p = actor.truth_enu_m[0]
        return Platform(actor.id, "anchor", None, (float(p[0]), float(p[1]), float(p[2])))
    drift = leader_drift_sigma_mps(params) if actor.nav == "gnss" else dr_drift_sigma_mps(params)
    return Platform(actor.id, actor.role, round(drift, 4))


def _navigate(
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


def _fault_rows(
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


def _logged(t_rel: np.ndarray, gaps: tuple[NavGapSpec, ...], pid: str) -> np.ndarray:
    """Nav epochs of ``pid`` outside its gaps (both ends of a gap included in it)."""
    keep = np.ones(t_rel.shape[0], dtype=bool)
    for gap in gaps:
        if gap.platform == pid:
            keep &= ~((t_rel >= gap.start_s - 1e-9) & (t_rel <= gap.end_s + 1e-9))
    return keep


def _check_epochs(
    params: SimParams,
    given: frozenset[str],
    range_times: Mapping[str, np.ndarray],
    nav_times: np.ndarray,
) -> None:
    """Refuse NLOS events, outages and nav gaps given explicitly that hold no epoch.

    (The scenario's own, moved with the session length, always hold one: :func:`_rescale`.)
    """
    session = f"the session is 0-{params.duration_s:g} s"
    if "nlos_events" in given:
        for event in params.nlos_events:
            t = range_times[event.pair]
            if not ((t >= event.start_s) & (t <= event.end_s)).any():
                raise ConfigError(
                    f"simulation parameter 'nlos_events': the event on {event.pair} at "
                    f"{event.start_s:g}-{event.end_s:g} s holds no range of the pair "
                    f"({session}, ranges at {params.range_rate_hz:g} Hz)"
                )
    if "outages" in given:
        every = np.concatenate([*range_times.values(), np.empty(0)])
        for outage in params.outages:
            if not ((every >= outage.start_s) & (every <= outage.end_s)).any():
                raise ConfigError(
                    f"simulation parameter 'outages': the outage at {outage.start_s:g}-"
                    f"{outage.end_s:g} s removes no range ({session})"
                )
    if "nav_gaps" in given:
        for gap in params.nav_gaps:
            if _logged(nav_times, (gap,), gap.platform).all():
                raise ConfigError(
                    f"simulation parameter 'nav_gaps': the gap of {gap.platform} at "
                    f"{gap.start_s:g}-{gap.end_s:g} s removes no nav row ({session}, nav "
                    f"at {params.nav_rate_hz:g} Hz)"
                )


def _check_gaps(params: SimParams, actors: tuple[Actor, ...], t_rel: np.ndarray) -> None:
    navigating = sorted(a.id for a in actors if a.nav != "none")
    for gap in params.nav_gaps:
        if gap.platform not in navigating:
            raise ConfigError(
                f"nav gap of '{gap.platform}': no such platform with navigation "
                f"(platforms: {', '.join(navigating)})"
            )
    for pid in navigating:
        if _logged(t_rel, params.nav_gaps, pid).sum() < 2:
            raise ConfigError(f"nav gaps of '{pid}' leave fewer than 2 nav epochs")
