"""Worlds of the INS scenarios (issue 12 item 6): platforms that carry an IMU and range to
fixed anchors, with a static start for the INS alignment.

- ``handcart`` (:func:`handcart`): paper 003 section 3's experiment. A handcart ``cart``
  with a tactical-grade IMU and a UWB tag 0.8 m above the ground stands still for the
  alignment, then is pushed at 0.6 m/s (paper: within +-0.8 m/s) along a '#'-shaped route
  inside a 40 x 30 m field of anchors: six around the area and one in its middle (paper
  003: stations 1-4, 6, 7 around, 5 in the middle). Pedestrians walking around the
  anchors cause short NLOS bursts on several anchors and, crowding around the cart, a
  short outage of every range.
- ``land-vehicle`` (:func:`land_vehicle`): a car ``car`` with an industrial-grade IMU and
  a wheel odometer (forward speed: the non-holonomic constraints hold, the body's lateral
  and vertical velocity are zero) drives a 200 x 80 m road loop at 8 m/s, ranging to
  anchors on poles 6 m beside the road; a longer UWB outage (a stretch without anchor
  coverage) and a few NLOS bursts (vehicles passing between the car and a pole).

The static start lasts ``STATIC_START_S`` (or a tenth of a shorter session): the platform
stands where its route starts, then ramps up to speed over 3 s
(:func:`coopproc.sim.formation.speed_profile_s`). Both platforms dead-reckon (role
``follower``, INS/odometer navigation file as in the other scenarios) and, by default,
also write raw IMU and odometer files (``imu_rate_hz`` 100 Hz).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from coopproc.errors import ConfigError
from coopproc.model import FloatArray
from coopproc.sim.formation import Terrain, path_positions, speed_profile_s
from coopproc.sim.params import NlosSpec, OutageSpec, SimParams
from coopproc.sim.paths import LoopPath, rounded_polygon, rounded_rectangle
from coopproc.sim.scenario_types import Actor, World, named_rng
from coopproc.sim.uwb import PairModel

__all__ = [
    "CART_SITES",
    "HANDCART_DEFAULTS",
    "LAND_VEHICLE_DEFAULTS",
    "POLE_SITES",
    "STATIC_START_S",
    "handcart",
    "land_vehicle",
    "static_start_s",
]

#: Static start (alignment) at the default session lengths, s, by scenario.
STATIC_START_S = {"handcart": 20.0, "land-vehicle": 10.0}

#: handcart anchors (east, north, up), m: the corners, the middle (paper 003 station 5),
#: the middles of the long sides, then one more on a short side (--platforms 9).
CART_SITES: tuple[tuple[float, float, float], ...] = (
    (-20.0, -15.0, 2.0), (20.0, -15.0, 2.1), (20.0, 15.0, 2.2), (-20.0, 15.0, 2.3),
    (0.0, 0.0, 1.5), (0.0, -15.0, 2.4), (0.0, 15.0, 2.5), (-20.0, 0.0, 2.6),
)  # fmt: skip
#: land-vehicle anchors on poles 6 m outside the 200 x 80 m road loop (east, north, up), m.
POLE_SITES: tuple[tuple[float, float, float], ...] = (
    (-106.0, -46.0, 3.0), (106.0, -46.0, 3.1), (106.0, 46.0, 3.2), (-106.0, 46.0, 3.3),
    (0.0, -46.0, 3.4), (0.0, 46.0, 3.5), (-50.0, 46.0, 3.6), (50.0, -46.0, 3.7),
)  # fmt: skip

#: The cart's '#' route (paper 003 figure 3), corners filleted with 1.5 m arcs.
_CART_ROUTE = (
    (-14.0, -6.0), (14.0, -6.0), (8.0, -12.0), (8.0, 12.0),
    (14.0, 6.0), (-14.0, 6.0), (-8.0, 12.0), (-8.0, -12.0),
)  # fmt: skip


def static_start_s(scenario: str, duration_s: float) -> float:
    """How long the platform stands still at the start: the scenario's static start, at
    most a tenth of the session."""
    return min(STATIC_START_S[scenario], 0.1 * duration_s)


def _drive(
    path: LoopPath, params: SimParams, rng: np.random.Generator, static_s: float, t: FloatArray
) -> FloatArray:
    """Arc lengths: standing still until ``static_s``, then the usual speed profile."""
    t_drive = np.maximum(t - static_s, 0.0)
    return speed_profile_s(t_drive, params.speed_mps, rng)


def _world(
    pid: str,
    path: LoopPath,
    sites: tuple[tuple[float, float, float], ...],
    antenna_m: float,
    scenario: str,
    params: SimParams,
    seed: int,
    t: FloatArray,
) -> World:
    count = params.platforms - 1
    if not 4 <= count <= len(sites):
        raise ConfigError(
            f"{scenario}: platforms must be 5..{len(sites) + 1} (one {pid} + "
            f"4..{len(sites)} anchors), found {params.platforms}"
        )
    terrain = Terrain(params.height_amplitude_m, named_rng(seed, "terrain"))
    s = _drive(path, params, named_rng(seed, pid), static_start_s(scenario, params.duration_s), t)
    pos = path_positions(path, s, terrain)
    pos[:, 2] += antenna_m
    actors = [Actor(pid, "follower", "dr", pos)]
    for k in range(count):
        site = np.array(sites[k], dtype=np.float64)
        actors.append(Actor(f"AN{k + 1}", "anchor", "none", np.tile(site, (t.shape[0], 1))))
    links = tuple(PairModel(pid, f"AN{k + 1}") for k in range(count))
    return World(time_rel_s=t, actors=tuple(actors), links=links)


def handcart(params: SimParams, seed: int, t: FloatArray) -> World:
    """Paper 003: the cart on the '#' route among 4..8 anchors (default 7)."""
    path = rounded_polygon(_CART_ROUTE, 1.5)
    return _world("cart", path, CART_SITES, 0.8, "handcart", params, seed, t)


def land_vehicle(params: SimParams, seed: int, t: FloatArray) -> World:
    """The car on a 200 x 80 m road loop (corner radius 15 m) among 4..8 roadside anchors."""
    path = rounded_rectangle(200.0, 80.0, 15.0)
    return _world("car", path, POLE_SITES, 1.6, "land-vehicle", params, seed, t)


#: handcart defaults: 240 s, the cart + 7 anchors, paper 003's speed and IMU (tactical;
#: 100 Hz here, the paper's 200 Hz with --imu 200), pedestrians: NLOS bursts of 4-8 s on
#: four anchors and an 8 s outage of every range.
HANDCART_DEFAULTS: dict[str, Any] = {
    "duration_s": 240.0,
    "platforms": 8,
    "speed_mps": 0.6,
    "height_amplitude_m": 0.05,
    "imu_rate_hz": 100.0,
    "imu_grade": "tactical",
    "nlos_events": (
        NlosSpec("AN3-cart", 40.0, 46.0, 0.7),
        NlosSpec("AN1-cart", 70.0, 74.0, 0.5),
        NlosSpec("AN5-cart", 100.0, 108.0, 0.9),
        NlosSpec("AN3-cart", 150.0, 155.0, 0.6),
        NlosSpec("AN2-cart", 185.0, 191.0, 0.8),
    ),
    # after the NLOS bursts: a shorter session (--duration) moves both to the same
    # fraction of it, and the outage would swallow a burst that came after it
    "outages": (OutageSpec(210.0, 218.0),),
}

#: land-vehicle defaults: 180 s (2.5 laps), the car + 6 anchors, 8 m/s, industrial IMU at
#: 100 Hz, odometer at 10 Hz, a 40 s outage, two NLOS bursts of 3-4 s.
LAND_VEHICLE_DEFAULTS: dict[str, Any] = {
    "duration_s": 180.0,
    "platforms": 7,
    "speed_mps": 8.0,
    "imu_rate_hz": 100.0,
    "nlos_events": (
        NlosSpec("AN2-car", 30.0, 34.0, 1.0),
        NlosSpec("AN5-car", 70.0, 73.0, 0.8),
    ),
    "outages": (OutageSpec(110.0, 150.0),),
}
