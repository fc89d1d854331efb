"""The scenario registry: what moves where, who ranges with whom, and the default figures.

Each scenario turns :class:`~coopproc.sim.params.SimParams` into a :class:`World`: the
true positions of every platform on the nav-rate time grid, their roles, the ranging
links and the NLOS events / outages (seconds from the session start). The engine
(:mod:`coopproc.sim.engine`) adds the sensors.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from coopproc.errors import ConfigError
from coopproc.model import FloatArray
from coopproc.sim.aux_worlds import multi_auxiliary, single_auxiliary
from coopproc.sim.formation import (
    Terrain,
    formation_positions,
    path_positions,
    speed_profile_s,
    wedge_layout,
)
from coopproc.sim.ins_worlds import (
    HANDCART_DEFAULTS,
    LAND_VEHICLE_DEFAULTS,
    handcart,
    land_vehicle,
)
from coopproc.sim.multirotor import QUADROTOR_DEFAULTS, quadrotor
from coopproc.sim.params import NavGapSpec, NlosSpec, OutageSpec, SimParams
from coopproc.sim.paths import rounded_polygon, rounded_rectangle
from coopproc.sim.scenario_types import Actor, World, named_rng
from coopproc.sim.uwb import PairModel

__all__ = ["SCENARIOS", "Actor", "Scenario", "World", "named_rng"]


@dataclass(frozen=True)
class Scenario:
    """A named scenario: its description, default parameters and its world builder.

    ``unused``: the parameters its world has nothing to act on (no GNSS/INS leader, no
    formation, no auxiliary), each with the reason; setting one is refused
    (:mod:`coopproc.sim.options`).
    """

    name: str
    description: str
    build: Callable[[SimParams, int, FloatArray], World]
    defaults: Mapping[str, Any] = field(default_factory=dict)
    unused: Mapping[str, str] = field(default_factory=dict)


def _all_links(ids: list[str]) -> tuple[PairModel, ...]:
    return tuple(PairModel(a, b) for i, a in enumerate(ids) for b in ids[i + 1 :])


def _formation_world(
    ids: list[str],
    path_size: tuple[float, float, float],
    params: SimParams,
    seed: int,
    t: FloatArray,
) -> World:
    """Leader ids[0] and followers ids[1:] in a wedge behind it on a rounded rectangle."""
    path = rounded_rectangle(*path_size)
    terrain = Terrain(params.height_amplitude_m, named_rng(seed, "terrain"))
    layout = wedge_layout(len(ids))
    pos = formation_positions(
        path, t, layout, params.speed_mps, params.distance_rate_mps, terrain,
        named_rng(seed, "formation"),
    )  # fmt: skip
    actors = tuple(
        Actor(pid, "leader" if k == 0 else "follower", "gnss" if k == 0 else "dr", pos[k])
        for k, pid in enumerate(ids)
    )
    return World(time_rel_s=t, actors=actors, links=_all_links(sorted(ids)))


_LETTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"


def _paper_experiment(params: SimParams, seed: int, t: FloatArray) -> World:
    # paper 000 section 4.1: trolley B (leader) in front, robots A and C behind
    if not 2 <= params.platforms <= len(_LETTERS):
        raise ConfigError(f"paper-experiment: platforms must be 2..26, found {params.platforms}")
    letters = list(_LETTERS[: params.platforms])
    ids = ["B", *[x for x in letters if x != "B"]]
    return _formation_world(ids, (160.0, 70.0, 18.0), params, seed, t)


def _body_blocked(params: SimParams, seed: int, t: FloatArray) -> World:
    # the paper-experiment formation with D, whose body blocks its own antenna
    if not 4 <= params.platforms <= len(_LETTERS):
        raise ConfigError(f"body-blocked: platforms must be 4..26, found {params.platforms}")
    return _paper_experiment(params, seed, t)


def _paper_table1(params: SimParams, seed: int, t: FloatArray) -> World:
    if params.platforms != 2:
        raise ConfigError(f"paper-table1: one pair, platforms must be 2, found {params.platforms}")
    return _formation_world(["B", "A"], (160.0, 70.0, 18.0), params, seed, t)


def _large(params: SimParams, seed: int, t: FloatArray) -> World:
    if params.platforms < 2:
        raise ConfigError(f"large: platforms must be >= 2, found {params.platforms}")
    ids = [f"P{k:02d}" for k in range(params.platforms)]
    return _formation_world(ids, (400.0, 200.0, 20.0), params, seed, t)


_ANCHOR_SITES = (
    (-20.0, -15.0), (20.0, -15.0), (20.0, 15.0), (-20.0, 15.0),
    (0.0, -15.0), (0.0, 15.0), (-20.0, 0.0), (20.0, 0.0),
)  # fmt: skip


def _anchors(params: SimParams, seed: int, t: FloatArray) -> World:
    # paper 003 section 3: a handcart with a UWB tag pushed along a '#'-shaped route
    # (< 0.8 m/s) inside a field of base stations, testers walking around one of them.
    count = params.platforms - 1
    if not 4 <= count <= len(_ANCHOR_SITES):
        raise ConfigError(
            f"anchors: platforms must be 5..9 (one tag + 4..8 anchors), found {params.platforms}"
        )
    terrain = Terrain(params.height_amplitude_m, named_rng(seed, "terrain"))
    route = [
        (-14.0, -6.0),
        (14.0, -6.0),
        (8.0, -12.0),
        (8.0, 12.0),
        (14.0, 6.0),
        (-14.0, 6.0),
        (-8.0, 12.0),
        (-8.0, -12.0),
    ]
    path = rounded_polygon(route, 1.5)
    tag = path_positions(
        path, speed_profile_s(t, params.speed_mps, named_rng(seed, "tag")), terrain
    )
    tag[:, 2] += 0.8  # tag antenna on the handcart
    actors = [Actor("tag", "follower", "dr", tag)]
    for k in range(count):
        site = np.array([*_ANCHOR_SITES[k], 2.0 + 0.1 * k])
        actors.append(Actor(f"AN{k + 1}", "anchor", "none", np.tile(site, (t.shape[0], 1))))
    links = tuple(PairModel("tag", f"AN{k + 1}") for k in range(count))
    return World(time_rel_s=t, actors=tuple(actors), links=links)


def _tag_only(params: SimParams, seed: int, t: FloatArray) -> World:
    # the anchors world with a tag that has no dead reckoning: no nav file, role "tag"
    world = _anchors(params, seed, t)
    tag = world.actors[0]
    actors = (Actor(tag.id, "tag", "none", tag.truth_enu_m), *world.actors[1:])
    return World(time_rel_s=world.time_rel_s, actors=actors, links=world.links)


#: paper 000 section 4.4: two NLOS events on each leader pair (the estimated means, rounded)
_PAPER_EVENTS = (
    NlosSpec("A-B", 120.0, 145.0, 0.58),
    NlosSpec("B-C", 230.0, 250.0, 0.50),
    NlosSpec("A-B", 380.0, 400.0, 0.47),
    NlosSpec("B-C", 470.0, 495.0, 0.55),
)

#: body-blocked: every pair of D in long NLOS whose mean wanders slowly (means 0.3-1.0 m)
_BODY_EVENTS = (
    NlosSpec("B-D", 30.0, 570.0, 0.6, 0.25),
    NlosSpec("A-D", 60.0, 200.0, 0.5, 0.2),
    NlosSpec("C-D", 100.0, 160.0, 0.4, 0.1),
    NlosSpec("C-D", 300.0, 500.0, 0.7, 0.25),
    NlosSpec("A-D", 350.0, 450.0, 0.8, 0.15),
)

#: The leader's GNSS/INS figures: nothing to act on without a GNSS/INS platform.
_LEADER_OPTIONS = (
    "leader_sigma_m",
    "leader_sigma_up_m",
    "leader_corr_s",
    "leader_white_m",
    "leader_velocity",
    "leader_vel_sigma_mps",
)
#: The options of paper 004's auxiliaries (single-auxiliary only).
_AUX_OPTIONS = ("aux_static", "second_aux", "aux2_bias_m", "aux2_noise_m")
#: The options of the multi-auxiliary layout (issue 17).
_MULTI_OPTIONS = ("aux_distance_m", "aux1_moves_at_s", "aux3_tail_m")

_NO_AUX = dict.fromkeys(_AUX_OPTIONS + _MULTI_OPTIONS, "no auxiliary A1/A2")
_ANCHORS_UNUSED = {
    **_NO_AUX,
    **dict.fromkeys(
        _LEADER_OPTIONS, "no GNSS/INS platform: the tag dead-reckons, the anchors stand still"
    ),
    "distance_rate_mps": "no formation: the tag follows a fixed route among fixed anchors",
}

#: Dead-reckoning options: the tag-only scenario has no navigation to act on.
_TAG_UNUSED = dict.fromkeys(
    (
        "gyro_bias_dph",
        "gyro_arw_dpsh",
        "heading_init_sigma_deg",
        "odo_scale_sigma",
        "odo_noise_m",
        "init_error_m",
        "height_rw_m",
        "heading_drift_dpm",
        "odo_scale_fault",
        "slip_rate_per_hour",
        "nav_gaps",
    ),
    "the tag has no dead reckoning",
)

SCENARIOS: dict[str, Scenario] = {
    "paper-experiment": Scenario(
        "paper-experiment",
        "paper 000 section 4.4: A, B (leader, GNSS/INS), C (INS/OD) in a triangle at 0.5 m/s, "
        "10 min, UWB 1 Hz, two NLOS events on A-B and two on B-C, A-C line of sight",
        _paper_experiment,
        {"duration_s": 600.0, "platforms": 3, "nlos_events": _PAPER_EVENTS},
        unused=_NO_AUX,
    ),
    "paper-table1": Scenario(
        "paper-table1",
        "paper 000 section 4.3: one pair, 2 min, ranges at 10 Hz, NLOS N(0.45, 0.1^2) at "
        "10-20 s, N(0.5, 0.1^2) at 50-60 s, N(0.6, 0.1^2) at 90-95 s",
        _paper_table1,
        {
            "duration_s": 120.0,
            "platforms": 2,
            "range_rate_hz": 10.0,
            "dropout_rate": 0.0,
            "nlos_events": (
                NlosSpec("A-B", 10.0, 20.0, 0.45),
                NlosSpec("A-B", 50.0, 60.0, 0.50),
                NlosSpec("A-B", 90.0, 95.0, 0.60),
            ),
        },
        unused=_NO_AUX,
    ),
    "anchors": Scenario(
        "anchors",
        "paper 003: one moving tag (INS dead reckoning) and 6 fixed anchors, NLOS on AN3, "
        "one 30 s UWB outage",
        _anchors,
        {
            "duration_s": 600.0,
            "platforms": 7,
            "speed_mps": 0.6,
            "height_amplitude_m": 0.05,
            "nlos_events": (
                NlosSpec("AN3-tag", 100.0, 130.0, 0.8),
                NlosSpec("AN3-tag", 350.0, 380.0, 0.6),
            ),
            "outages": (OutageSpec(450.0, 480.0),),
        },
        unused=_ANCHORS_UNUSED,
    ),
    "tag-only": Scenario(
        "tag-only",
        "paper 003 without the INS: one tag with no dead reckoning (role tag, no nav file) "
        "among 6 fixed anchors on the anchors route, pedestrians blocking AN3 (NLOS), one "
        "30 s UWB outage",
        _tag_only,
        {
            "duration_s": 600.0,
            "platforms": 7,
            "speed_mps": 0.6,
            "height_amplitude_m": 0.05,
            "nlos_events": (
                NlosSpec("AN3-tag", 100.0, 130.0, 0.8),
                NlosSpec("AN3-tag", 350.0, 380.0, 0.6),
            ),
            "outages": (OutageSpec(450.0, 480.0),),
        },
        unused={**_ANCHORS_UNUSED, **_TAG_UNUSED},
    ),
    "handcart": Scenario(
        "handcart",
        "paper 003 with raw IMU: a handcart (tactical IMU at 100 Hz, INS/odometer nav) "
        "standing 20 s for the alignment, then pushed at 0.6 m/s along the '#' route among "
        "7 anchors (one in the middle); pedestrians: 4-8 s NLOS bursts, an 8 s outage",
        handcart,
        HANDCART_DEFAULTS,
        unused=_ANCHORS_UNUSED,
    ),
    "land-vehicle": Scenario(
        "land-vehicle",
        "a car (industrial IMU at 100 Hz, odometer: non-holonomic) standing 10 s, then "
        "driving a 200 x 80 m road loop at 8 m/s among 6 roadside anchors on poles; a 40 s "
        "UWB outage, two NLOS bursts",
        land_vehicle,
        LAND_VEHICLE_DEFAULTS,
        unused=_ANCHORS_UNUSED,
    ),
    "quadrotor": Scenario(
        "quadrotor",
        "issue 31: 3 drones (consumer IMU at 200 Hz, no navigation file, role tag) flying "
        "3-D curves in a 6.5 x 7 m lab from the first sample on (no static start), each "
        "ranging its 6 anchors in turn at 2 Hz (one range per anchor every 3 s); two "
        "10 s NLOS bursts on ifo001",
        quadrotor,
        QUADROTOR_DEFAULTS,
        unused={
            **_ANCHORS_UNUSED,
            **_TAG_UNUSED,
            "distance_rate_mps": "no formation: each drone flies a curve of its own",
            "height_amplitude_m": "no terrain: the drones fly their own heights",
        },
    ),
    "single-auxiliary": Scenario(
        "single-auxiliary",
        "paper 004 section 5: target T with dead reckoning in its own frame (unknown start "
        "and azimuth), moving GNSS auxiliary A1; options aux_static, second_aux (A2, biased)",
        single_auxiliary,
        {"duration_s": 300.0, "platforms": 2, "speed_mps": 1.0, "distance_rate_mps": 0.0},
        unused={
            "distance_rate_mps": "no formation: T, A1 and A2 drive loops of their own",
            **dict.fromkeys(
                _MULTI_OPTIONS, "a fixed layout of A1 and A2; the multi-auxiliary one has these"
            ),
        },
    ),
    "multi-auxiliary": Scenario(
        "multi-auxiliary",
        "issue 17 / paper 004 sec. 5.2: target T (own-frame dead reckoning, 2 % odometer "
        "scale fault) on a 24 x 16 m loop; A1 (good), A2 (peak-shifted Laplace) and A3 "
        "(heavy-tailed Student t) on 8 m loops 60 m away (aux_distance_m), UWB noise 0.1 m",
        multi_auxiliary,
        {
            "duration_s": 300.0,
            "platforms": 4,
            "speed_mps": 1.0,
            "distance_rate_mps": 0.0,
            "uwb_noise_m": 0.1,
            "odo_scale_fault": (0.02, 0.02),
        },
        unused={
            "distance_rate_mps": "no formation: T and the auxiliaries drive loops of their own",
            "second_aux": "the auxiliaries are set by the platform count (2-4)",
        },
    ),
    "large": Scenario(
        "large",
        "N platforms (default 10) in a wedge for hours (default 1 h), random NLOS events, "
        "for benchmarks",
        _large,
        {"duration_s": 3600.0, "platforms": 10, "random_nlos_per_pair_hour": 0.5},
        unused=_NO_AUX,
    ),
    # how processing fails on real data (issue 10, item 8)
    "dr-faults": Scenario(
        "dr-faults",
        "paper-experiment formation with A, B (leader), C, D whose dead reckoning has faults "
        "the declared drift_sigma does not cover: a 3 deg/min heading-rate error on A, "
        "odometer scale errors of 1-3 % and wheel slips (2-6 s, 20-50 % over-read) on every "
        "follower; the paper's NLOS events",
        _paper_experiment,
        {
            "duration_s": 600.0,
            "platforms": 4,
            "nlos_events": _PAPER_EVENTS,
            "heading_drift_dpm": 3.0,
            "odo_scale_fault": (0.01, 0.03),
            "slip_rate_per_hour": 30.0,
        },
        unused=_NO_AUX,
    ),
    "noisy-leader": Scenario(
        "noisy-leader",
        "paper-experiment whose leader B's 10 Hz GNSS/INS has 2.5 cm white noise per axis on "
        "top of the correlated part, and velocities (vel_east/north/up, 2 cm/s noise) in "
        "its nav file; the paper's NLOS events",
        _paper_experiment,
        {
            "duration_s": 600.0,
            "platforms": 3,
            "nlos_events": _PAPER_EVENTS,
            "leader_white_m": 0.025,
            "leader_velocity": True,
            "leader_vel_sigma_mps": 0.02,
        },
        unused=_NO_AUX,
    ),
    "body-blocked": Scenario(
        "body-blocked",
        "paper-experiment formation with A, B (leader), C, D in which D's own body blocks "
        "every pair of D, as on the real TIERS tb4 pairs: long NLOS (60-200 s, and B-D for "
        "540 s), means 0.4-0.8 m wandering slowly by up to 0.25 m",
        _body_blocked,
        {"duration_s": 600.0, "platforms": 4, "nlos_events": _BODY_EVENTS},
        unused=_NO_AUX,
    ),
    "nav-gaps": Scenario(
        "nav-gaps",
        "paper-experiment in which A's nav file has no rows for 60 s in the middle "
        "(270-330 s) and C's ends 60 s before the ranges do; the paper's NLOS events",
        _paper_experiment,
        {
            "duration_s": 600.0,
            "platforms": 3,
            "nlos_events": _PAPER_EVENTS,
            "nav_gaps": (NavGapSpec("A", 270.0, 330.0), NavGapSpec("C", 540.0, 600.0)),
        },
        unused=_NO_AUX,
    ),
}
