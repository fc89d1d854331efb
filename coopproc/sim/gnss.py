"""Leader navigation (GNSS/INS, centimetre noise) and the GNSS-PPK reference trajectories.

- Leader: truth + first-order Gauss-Markov noise per axis (sigma, correlation time tau),
  x_k = a x_{k-1} + sqrt(1 - a^2) sigma w_k with a = exp(-dt / tau), via ``lfilter``;
  optionally (:func:`leader_jitter`) white noise at the nav rate on top, as a real 10 Hz
  GNSS/INS solution has, and a velocity (true velocity + white noise).
- Reference: truth at the reference rate + white noise of a fixed (Q = 1) solution; a few
  segments of 10-20 s are float (Q = 2) with decimetre-level noise, as PPK has at times.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from coopproc.model import FloatArray
from coopproc.sim.params import SimParams

__all__ = ["gauss_markov", "leader_drift_sigma_mps", "leader_jitter", "leader_nav", "ppk_reference"]


def gauss_markov(
    n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator
) -> FloatArray:
    """A stationary first-order Gauss-Markov sequence of length ``n`` (1-sigma ``sigma``)."""
    if sigma == 0.0 or n == 0:
        return np.zeros(n)
    a = float(np.exp(-dt_s / tau_s)) if tau_s > 0 else 0.0
    w = rng.normal(0.0, 1.0, size=n) * sigma * np.sqrt(1.0 - a * a)
    w[0] = rng.normal(0.0, sigma)
    return np.asarray(lfilter([1.0], [1.0, -a], w), dtype=np.float64)


def leader_nav(
    truth_enu_m: FloatArray,
    truth_heading_deg: FloatArray,
    time_s: FloatArray,
    params: SimParams,
    rng: np.random.Generator,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """GNSS/INS solution of a leader: (n, 3) positions, (n,) heading deg, (n, 3) 1-sigma."""
    n = truth_enu_m.shape[0]
    dt = float(np.median(np.diff(time_s))) if n > 1 else 1.0
    sig = (params.leader_sigma_m, params.leader_sigma_m, params.leader_sigma_up_m)
    noise = np.column_stack([gauss_markov(n, dt, s, params.leader_corr_s, rng) for s in sig])
    heading = np.mod(truth_heading_deg + rng.normal(0.0, 0.1, size=n), 360.0)
    sigma = np.tile(np.asarray(sig, dtype=np.float64), (n, 1))
    return truth_enu_m + noise, heading, sigma


def leader_jitter(
    truth_enu_m: FloatArray, time_s: FloatArray, params: SimParams, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray | None]:
    """(n, 3) white position noise (``leader_white_m`` per axis) and, with
    ``leader_velocity``, the (n, 3) velocity: central differences of the truth plus
    white noise ``leader_vel_sigma_mps`` per axis (else None)."""
    n = truth_enu_m.shape[0]
    white = rng.normal(0.0, 1.0, size=(n, 3)) * params.leader_white_m
    if not params.leader_velocity or n < 2:
        return white, None
    vel = np.gradient(truth_enu_m, time_s, axis=0)
    return white, vel + rng.normal(0.0, 1.0, size=(n, 3)) * params.leader_vel_sigma_mps


def leader_drift_sigma_mps(params: SimParams) -> float:
    """Declared drift_sigma of a leader: 1-sigma of the 1-s increment of its GNSS/INS noise
    (Gauss-Markov part, plus sqrt(2) x the white part where there is one)."""
    a = np.exp(-1.0 / params.leader_corr_s) if params.leader_corr_s > 0 else 0.0
    markov = float(params.leader_sigma_m * np.sqrt(2.0 * (1.0 - a)))
    if params.leader_white_m == 0.0:
        return markov
    return float(np.hypot(markov, np.sqrt(2.0) * params.leader_white_m))


def ppk_reference(
    truth_enu_m: FloatArray,
    time_s: FloatArray,
    params: SimParams,
    rng: np.random.Generator,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64]]:
    """Reference positions (n, 3), 1-sigma (n, 3) and RTKLIB Q (n,) at ``time_s``."""
    n = truth_enu_m.shape[0]
    quality = np.ones(n, dtype=np.int64)
    duration = float(time_s[-1] - time_s[0]) if n else 0.0
    float_total = params.float_fraction * duration
    if float_total > 0 and duration > 60.0:
        segments = max(1, round(float_total / 15.0))
        lengths = rng.uniform(10.0, 20.0, size=segments) * float_total / (15.0 * segments)
        starts = rng.uniform(time_s[0] + 20.0, time_s[-1] - 20.0 - lengths)
        for start, length in zip(starts, lengths, strict=True):
            quality[(time_s >= start) & (time_s < start + length)] = 2
    fixed = np.array([params.ref_sigma_m, params.ref_sigma_m, params.ref_sigma_up_m])
    flo = np.array([params.float_sigma_m, params.float_sigma_m, 2.0 * params.float_sigma_m])
    sigma = np.where((quality == 2)[:, None], flo[None, :], fixed[None, :])
    noise = rng.normal(0.0, 1.0, size=(n, 3)) * sigma
    return truth_enu_m + noise, sigma, quality
