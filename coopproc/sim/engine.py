"""``simulate``: a scenario's world + sensors -> an in-memory Session and its Truth.

Everything is drawn from ``numpy.random.default_rng`` streams keyed by (seed, name), so
a seed gives the same session bit for bit, and all per-sample work is vectorized. The
effective parameters are :mod:`coopproc.sim.resolve` (``scenario_params`` is re-exported
here), each actor's own navigation :mod:`coopproc.sim.navigate`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError
from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory
from coopproc.sim.gnss import ppk_reference
from coopproc.sim.gnss_obs import add_gnss_obs, gnss_session_params
from coopproc.sim.imu import add_raw_sensors
from coopproc.sim.navigate import actor_platform, dr_fault_rows, heading_of, navigate, own_frame
from coopproc.sim.params import NlosSpec, OutageSpec, SimParams
from coopproc.sim.resolve import (
    check_epochs,
    check_gaps,
    logged_mask,
    nav_times_rel,
    resolve,
    scenario_params,
)
from coopproc.sim.scenarios import SCENARIOS, named_rng
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
    params, given, changed = resolve(
        scenario, {"duration_s": duration_s, "platforms": platforms, **overrides}
    )
    params = gnss_session_params(params, given)  # the ephemerides' time (gnss_obs only)
    t_rel = nav_times_rel(params)
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
    check_gaps(params, world.actors, t_rel)
    fault_rows: list[list[object]] = []
    # the heading-rate fault goes to the first dead-reckoning platform in sorted order
    drifting = min((a.id for a in world.actors if a.nav == "dr"), default=None)
    for actor in sorted(world.actors, key=lambda a: a.id):
        heading = heading_of(actor.truth_enu_m)
        if actor.yaw_rad is not None:  # a body that does not point along its course
            heading = np.mod(90.0 - np.degrees(actor.yaw_rad), 360.0)
        truth = Trajectory(actor.id, time, actor.truth_enu_m, heading_deg=heading, source="truth")
        truth_traj[actor.id] = truth
        plats[actor.id] = actor_platform(actor, params)
        if actor.role != "anchor":  # a tag has no nav file but a reference
            ref_pos, ref_sigma, quality = ppk_reference(
                truth.interpolate(t_ref), t_ref, params, named_rng(seed, f"ref:{actor.id}")
            )
            reference[actor.id] = Trajectory(
                actor.id, t_ref, ref_pos, sigma_enu_m=ref_sigma, quality=quality, source="simulated"
            )
        if actor.nav == "none":
            continue
        pos, head, sigma, vel, errors = navigate(
            actor, heading, time, params, seed, drifting=actor.id == drifting
        )
        if errors is not None:
            fault_rows += dr_fault_rows(actor.id, errors, start, params.duration_s, t_rel)
            dr_param_rows.append(
                [
                    actor.id,
                    errors.gyro_bias_dph,
                    errors.odo_scale,
                    errors.heading_init_deg,
                    *errors.init_error_m,
                ]
            )
        logged = logged_mask(t_rel, params.nav_gaps, actor.id)
        for gap in (g for g in params.nav_gaps if g.platform == actor.id):
            removed = int((~logged_mask(t_rel, (gap,), actor.id)).sum())
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
            pos, head = own_frame(pos, head, shift, rotation)
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

    pairs = sorted(link.pair for link in world.links)
    events = [*params.nlos_events, *_random_events(params, pairs, seed)]
    unknown = sorted({e.pair for e in events} - set(pairs))
    if unknown:
        raise ConfigError(
            f"NLOS events on pairs without ranging: {', '.join(unknown)} "
            f"(pairs: {', '.join(pairs)})"
        )
    check_epochs(params, given, range_times_rel(truth_traj, world.links, params, start), t_rel)
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
    sim = Simulation(scenario=scenario, seed=seed, session=session, truth=truth_obj)
    sim = add_raw_sensors(sim)  # imu_<ID>.csv, odo_<ID>.csv: only with imu_rate_hz > 0
    return add_gnss_obs(sim)  # obs_<ID>, nav: only with gnss_obs
