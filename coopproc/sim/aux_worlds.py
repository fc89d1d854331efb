"""Worlds of paper 004 (cooperative localization from auxiliaries): a target T that only
dead-reckons, in its own frame, and GNSS auxiliaries A1, A2, A3 that range with it.

- ``single-auxiliary`` (:func:`single_auxiliary`): T drives an 80 x 60 m loop, A1 a 15 m
  radius loop inside it (or stands still); an optional A2 with peak-shifted Laplace noise.
- ``multi-auxiliary`` (:func:`multi_auxiliary`, issue 17): T drives a 24 x 16 m loop;
  A1 (good ranging), A2 (peak-shifted, Laplace: paper 004 sec. 5.2) and A3 (heavy-tailed,
  Student t with 2 degrees of freedom: "noise that exceeds the measurement error
  threshold", Fig. 13) drive 8 x 8 m loops whose centres are ``aux_distance_m`` from T's
  (bearings 30, 150 and 270 degrees), so a far layout (60 m) keeps them 45-75 m away
  and a near one (15 m) 5-30 m. A1 may stand still until ``aux1_moves_at_s``.
"""

from __future__ import annotations

import numpy as np

from coopproc.errors import ConfigError
from coopproc.model import FloatArray
from coopproc.sim.formation import Terrain, path_positions, speed_profile_s
from coopproc.sim.params import SimParams
from coopproc.sim.paths import rounded_rectangle
from coopproc.sim.scenario_types import Actor, World, named_rng
from coopproc.sim.uwb import PairModel

__all__ = ["AUX_BEARINGS_DEG", "multi_auxiliary", "single_auxiliary"]

#: Bearings (degrees clockwise from north) of A1, A2, A3's loop centres from T's.
AUX_BEARINGS_DEG = (30.0, 150.0, 270.0)


def _loop_positions(
    path_size: tuple[float, float, float],
    centre: tuple[float, float],
    speed: float,
    s0: float,
    terrain: Terrain,
    t: FloatArray,
    rng: np.random.Generator,
) -> FloatArray:
    path = rounded_rectangle(*path_size, centre_m=centre)
    return path_positions(path, speed_profile_s(t, speed, rng, s0_m=s0), terrain)


def single_auxiliary(params: SimParams, seed: int, t: FloatArray) -> World:
    # paper 004 section 5: the target car T drives a closed loop around the site; the
    # auxiliary trolley A1 (GNSS) moves inside it (or stands still: unobservable case);
    # an optional second auxiliary A2 has peak-shifted, non-Gaussian ranging (5.2).
    second = params.second_aux or params.platforms == 3
    if params.platforms not in (2, 3):
        raise ConfigError(
            "single-auxiliary: platforms must be 2 (T, A1) or 3 (T, A1, A2), "
            f"found {params.platforms}"
        )
    terrain = Terrain(params.height_amplitude_m, named_rng(seed, "terrain"))
    target = _loop_positions(
        (80.0, 60.0, 10.0), (0.0, 0.0), params.speed_mps, 0.0, terrain, t, named_rng(seed, "T")
    )
    if params.aux_static:
        rest = np.array([[6.0, 4.0]])
        aux1 = np.column_stack(
            (np.repeat(rest, t.shape[0], axis=0), terrain.up(rest).repeat(t.shape[0]))
        )
    else:
        aux1 = _loop_positions(
            (30.0, 30.0, 14.99), (0.0, 0.0), 0.6, 20.0, terrain, t, named_rng(seed, "A1")
        )
    actors = [
        Actor("T", "follower", "dr", target, own_frame=True),
        Actor("A1", "leader", "gnss", aux1),
    ]
    links = [PairModel("A1", "T")]
    if second:
        aux2 = _loop_positions(
            (16.0, 16.0, 7.99), (-18.0, 8.0), 0.5, 5.0, terrain, t, named_rng(seed, "A2")
        )
        actors.append(Actor("A2", "leader", "gnss", aux2))
        links.append(PairModel("A2", "T", bias_m=params.aux2_bias_m, laplace_m=params.aux2_noise_m))
    return World(time_rel_s=t, actors=tuple(actors), links=tuple(links))


def multi_auxiliary(params: SimParams, seed: int, t: FloatArray) -> World:
    """T on a 24 x 16 m loop; A1..A(platforms-1) on 8 x 8 m loops ``aux_distance_m`` away.

    A1 ranges like the others' nominal model (Gaussian ``uwb_noise_m``); A2 adds the
    peak shift ``aux2_bias_m`` with Laplace noise ``aux2_noise_m``; A3 has Student-t
    (2 dof) noise of scale ``aux3_tail_m``. With ``aux_static`` A1 never moves; with
    ``aux1_moves_at_s`` > 0 it stands where its loop starts until then.
    """
    if not 2 <= params.platforms <= 4:
        raise ConfigError(
            "multi-auxiliary: platforms must be 2..4 (T and A1, A2 peak-shifted, "
            f"A3 heavy-tailed), found {params.platforms}"
        )
    terrain = Terrain(params.height_amplitude_m, named_rng(seed, "terrain"))
    target = _loop_positions(
        (24.0, 16.0, 6.0), (0.0, 0.0), params.speed_mps, 0.0, terrain, t, named_rng(seed, "T")
    )
    actors = [Actor("T", "follower", "dr", target, own_frame=True)]
    links = []
    for k in range(params.platforms - 1):
        pid = f"A{k + 1}"
        b = np.radians(AUX_BEARINGS_DEG[k])
        centre = (params.aux_distance_m * np.sin(b), params.aux_distance_m * np.cos(b))
        pos = _loop_positions(
            (8.0, 8.0, 3.99), centre, 0.6, 7.0 * k, terrain, t, named_rng(seed, pid)
        )
        if k == 0 and (params.aux_static or params.aux1_moves_at_s > 0):
            # standing where its loop starts until it moves (never with aux_static)
            start_s = params.duration_s + 1.0 if params.aux_static else params.aux1_moves_at_s
            t_drive = np.maximum(t - start_s, 0.0)
            pos = _loop_positions(
                (8.0, 8.0, 3.99), centre, 0.6, 0.0, terrain, t_drive, named_rng(seed, pid)
            )
        actors.append(Actor(pid, "leader", "gnss", pos))
        if k == 0:
            links.append(PairModel(pid, "T"))
        elif k == 1:
            links.append(
                PairModel(pid, "T", bias_m=params.aux2_bias_m, laplace_m=params.aux2_noise_m)
            )
        else:
            links.append(PairModel(pid, "T", student_t_m=params.aux3_tail_m))
    return World(time_rel_s=t, actors=tuple(actors), links=tuple(links))
