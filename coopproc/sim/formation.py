"""True motion: a leader on a loop, followers in lanes beside and behind it, terrain height.

The leader drives the loop at a slowly varying speed. Each follower drives its own lane:
it sits ``lag`` metres of path behind the leader and ``lateral`` metres to the left of the
path (paper 000 section 4.1: trolley B in front, robots A and C behind, a triangle).
Real drivers do not hold a rigid formation: lag and lateral offset wander as smooth
random processes (three sinusoids each, periods 40-150 s, random phases) whose scale is
calibrated so that the RMS rate of change of the true inter-platform distances equals
``distance_rate_mps`` (the smoothness statistic of DATA.md needs a moving truth).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from coopproc.model import FloatArray
from coopproc.sim.paths import LoopPath

__all__ = [
    "Terrain",
    "distance_rate_rms",
    "formation_positions",
    "path_positions",
    "speed_profile_s",
    "wedge_layout",
]

#: Lateral wander relative to the lag wander (equal: every pair of the triangle breathes).
_LATERAL_RATIO = 1.0


class Terrain:
    """Smooth height field: up = a (sin(2 pi e / 70 + p1) + sin(2 pi n / 55 + p2)) / 2."""

    def __init__(self, amplitude_m: float, rng: np.random.Generator) -> None:
        self.amplitude_m = amplitude_m
        self.phase = rng.uniform(0.0, 2.0 * np.pi, size=2)

    def up(self, en_m: FloatArray) -> FloatArray:
        e, n = en_m[..., 0], en_m[..., 1]
        wave = np.sin(2 * np.pi * e / 70.0 + self.phase[0])
        wave = wave + np.sin(2 * np.pi * n / 55.0 + self.phase[1])
        return np.asarray(0.5 * self.amplitude_m * wave, dtype=np.float64)


def speed_profile_s(
    time_s: FloatArray, speed_mps: float, rng: np.random.Generator, s0_m: float = 0.0
) -> FloatArray:
    """Arc length travelled at ``time_s`` (from 0): speed ramps up over 3 s, then varies +-5 %."""
    phase = rng.uniform(0.0, 2.0 * np.pi)
    ramp = np.clip(time_s / 3.0, 0.0, 1.0)
    v = speed_mps * ramp * (1.0 + 0.05 * np.sin(2 * np.pi * time_s / 97.0 + phase))
    ds = 0.5 * (v[1:] + v[:-1]) * np.diff(time_s)
    return np.asarray(s0_m + np.concatenate(([0.0], np.cumsum(ds))), dtype=np.float64)


def path_positions(path: LoopPath, s_m: FloatArray, terrain: Terrain) -> FloatArray:
    """(n, 3) ENU positions of a platform driving ``path`` at arc lengths ``s_m``."""
    en = path.position(s_m)
    return np.column_stack((en, terrain.up(en)))


def wedge_layout(
    count: int, lag_m: float = 18.0, lateral_m: float = 9.0
) -> list[tuple[float, float]]:
    """(lag, lateral) of the leader and ``count - 1`` followers in a wedge behind it.

    Follower k (1-based) is ceil(k / 2) rows back, alternately left and right.
    """
    layout = [(0.0, 0.0)]
    for k in range(1, count):
        row = (k + 1) // 2
        layout.append((lag_m * row, lateral_m if k % 2 == 1 else -lateral_m))
    return layout


def _unit_wander(
    time_s: FloatArray, rng: np.random.Generator, count: int
) -> tuple[FloatArray, FloatArray]:
    """(count, n) lag and lateral wander whose time derivatives have RMS 1 and 0.5 m/s."""
    out = []
    for ratio in (1.0, _LATERAL_RATIO):
        period = rng.uniform(40.0, 150.0, size=(count, 3))
        omega = 2 * np.pi / period
        phase = rng.uniform(0.0, 2 * np.pi, size=(count, 3))
        # derivative RMS of sum c_j sin(w_j t + p_j) is sqrt(sum c_j^2 w_j^2 / 2)
        c = ratio * np.sqrt(2.0 / 3.0) / omega
        wave = (c[:, :, None] * np.sin(omega[:, :, None] * time_s + phase[:, :, None])).sum(1)
        out.append(wave - (c * np.sin(phase)).sum(1)[:, None])  # zero at the start
    return out[0], out[1]


def _lane_positions(
    path: LoopPath,
    s_leader: FloatArray,
    lag_m: FloatArray,
    lateral_m: FloatArray,
    terrain: Terrain,
) -> FloatArray:
    s = s_leader - lag_m
    en = path.position(s) + lateral_m[:, None] * path.left_normal(s)
    return np.column_stack((en, terrain.up(en)))


def distance_rate_rms(positions_m: FloatArray, time_s: FloatArray) -> float:
    """RMS over all pairs of d/dt of the true distances; ``positions_m`` is (P, n, 3)."""
    p = positions_m.shape[0]
    rates = []
    dt = np.diff(time_s)
    for i in range(p):
        for j in range(i + 1, p):
            d = np.linalg.norm(positions_m[i] - positions_m[j], axis=1)
            rates.append(np.diff(d) / dt)
    if not rates:
        return 0.0
    return float(np.sqrt(np.mean(np.concatenate(rates) ** 2)))


def formation_positions(
    path: LoopPath,
    time_s: FloatArray,
    layout: Sequence[tuple[float, float]],
    speed_mps: float,
    distance_rate_mps: float,
    terrain: Terrain,
    rng: np.random.Generator,
) -> FloatArray:
    """(P, n, 3) true ENU positions of a leader (layout[0]) and its followers at ``time_s``."""
    count = len(layout)
    max_lag = max(lag for lag, _ in layout)
    s_leader = speed_profile_s(time_s, speed_mps, rng, s0_m=max_lag + 5.0)
    lag0 = np.array([lag for lag, _ in layout])
    lat0 = np.array([lat for _, lat in layout])
    wander_lag, wander_lat = _unit_wander(time_s, rng, count)
    wander_lag[0] = 0.0
    wander_lat[0] = 0.0

    def build(scale: float, index: slice | NDArray[np.intp]) -> FloatArray:
        return np.stack(
            [
                _lane_positions(
                    path,
                    s_leader[index],
                    lag0[k] + scale * wander_lag[k][index],
                    lat0[k] + scale * wander_lat[k][index],
                    terrain,
                )
                for k in range(count)
            ]
        )

    # calibrate the wander scale on a ~1 s subsample (the rate statistic of the ranges)
    step = max(1, round(1.0 / float(np.median(np.diff(time_s))))) if len(time_s) > 1 else 1
    sub = np.arange(0, len(time_s), step)
    scale = 0.0
    if count > 1 and len(sub) > 2 and distance_rate_mps > 0:

        def excess(k: float) -> float:
            return distance_rate_rms(build(k, sub), time_s[sub]) - distance_rate_mps

        if excess(0.0) < 0.0:
            high = 0.05
            while excess(high) < 0.0 and high < 10.0:
                high *= 2.0
            scale = float(brentq(excess, 0.0, high, xtol=1e-05)) if excess(high) >= 0.0 else high
    return build(scale, slice(None))
