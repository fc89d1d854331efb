"""Self-calibration of the ranging noise from the data (issue 10: the declared sigma is a prior).

Per pair, the ranges L_k and the distance increments I_k that drive the distance filter give
the series ``z_k = L_k - sum_{j <= k} I_j``: the (constant) initial distance plus the range
error minus the accumulated DI error. Its structure function

    V(tau) = E[(z(t + tau) - z(t))^2] = 2 sigma_w^2 + q tau  (+ higher order)

separates the white range noise sigma_w (measured on its own by :func:`white_sigma`) from
everything that grows with the lag: the random walk of the accumulated DI error and the
slowly varying (coloured) part of real UWB errors (multipath, antenna orientation). Both
belong in the distance filter's process noise: a DI that disagrees with the ranges beyond
what the white noise explains is leaned on less. V is estimated robustly ((1.4826 MAD)^2
of the lagged differences), so the jumps at the edges of NLOS events (a minority of the
differences) do not inflate it.

The innovation spread of the filter itself (residuals r = L - D' of eq. (9)) is the other
figure taken from the data: the detection threshold gamma_max of eq. (9) is gamma_sigma
times the robust spread of those residuals, combined with the declared sigma as a prior
(:func:`coopproc.estimation.sigma_prior.posterior_sigma`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from coopproc.estimation.robust import MAD_SCALE
from coopproc.model import FloatArray

__all__ = [
    "MAD_SCALE",
    "PairNoise",
    "accumulated",
    "pair_noise",
    "robust_sigma",
    "steady_gain",
    "white_sigma",
    "window_ids",
]

#: Fewer usable differences than this: no estimate (the caller keeps its prior).
MIN_SAMPLES = 20
#: More values than this: the MAD is taken of an evenly thinned subset.
MAX_SAMPLES = 20_000


@dataclass(frozen=True)
class PairNoise:
    """What the data of one pair says about its noise (NaN: not enough data)."""

    white_sigma_m: float  # sigma_w, the white UWB noise (structure-function intercept)
    growth_m2ps: float  # q, growth of V(tau) per second: DI random walk + coloured range error
    samples: int  # lagged differences behind the estimate


def accumulated(increments_m: FloatArray) -> FloatArray:
    """The running sum of a per-interval series (row k: from epoch k-1 to k; row 0 unused),
    NaN taken as 0: the distance change the DI has accumulated since the first epoch."""
    inc = np.where(np.isfinite(increments_m), increments_m, 0.0)
    inc[:1] = 0.0
    return np.cumsum(inc)


def window_ids(time_s: FloatArray, window_s: float) -> np.ndarray:
    """Calibration window (local.py) of each epoch, on the grid fixed at the first epoch."""
    if time_s.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    return np.floor((time_s - time_s[0]) / window_s + 1e-9).astype(np.int64)


def window_slices(time_s: FloatArray, window_s: float) -> list[tuple[int, int]]:
    """(first, end) row of each calibration window of :func:`window_ids` (time-sorted
    rows; empty windows give empty slices)."""
    if time_s.shape[0] == 0:
        return []
    win = window_ids(time_s, window_s)
    bounds = np.searchsorted(win, np.arange(int(win[-1]) + 2))
    return list(itertools.pairwise(bounds.tolist()))


def robust_sigma(values: FloatArray) -> float:
    """1.4826 MAD of the finite values (NaN when fewer than :data:`MIN_SAMPLES`); of every
    k-th value when there are more than :data:`MAX_SAMPLES` (a deterministic thinning:
    the MAD of 20,000 values is within 1 % of that of all)."""
    v = values[np.isfinite(values)]
    if v.shape[0] > MAX_SAMPLES:
        v = v[:: -(-v.shape[0] // MAX_SAMPLES)]
    if v.shape[0] < MIN_SAMPLES:
        return float("nan")
    return MAD_SCALE * float(np.median(np.abs(v - np.median(v))))


def _thinned(count: int, first: int) -> np.ndarray:
    """``count`` consecutive indices from ``first``, every k-th when more than
    :data:`MAX_SAMPLES` (deterministic: the statistics need no more)."""
    step = max(-(-count // MAX_SAMPLES), 1)
    return np.arange(first, first + count, step)


def _lagged_variance(time_s: FloatArray, z: FloatArray, lag_s: float) -> tuple[float, float, int]:
    """Robust variance of z(t + lag) - z(t) over the epochs (every k-th past
    :data:`MAX_SAMPLES`), and the mean actual lag."""
    start = _thinned(time_s.shape[0], 0)
    j = np.searchsorted(time_s, time_s[start] + lag_s - 1e-9)
    ok = j < time_s.shape[0]
    i = start[ok]
    j = j[ok]
    d = z[j] - z[i]
    lag = time_s[j] - time_s[i]
    keep = np.isfinite(d) & (lag > 0) & (lag < 2.0 * lag_s + 1e-9)
    s = robust_sigma(d[keep])
    if not np.isfinite(s):
        return float("nan"), float("nan"), 0
    return s * s, float(np.mean(lag[keep])), int(np.count_nonzero(keep))


def white_sigma(time_s: FloatArray, series: FloatArray) -> float:
    """White noise 1-sigma of a series from its departures from the line through each
    epoch's two neighbours: e_k = y_k - (a y_{k-1} + b y_{k+1}) with the interpolation
    weights a, b, var(e_k) = sigma^2 (1 + a^2 + b^2) for white noise; robust (MAD).
    Slow errors and smooth motion cancel to second order. NaN when too short."""
    t = np.asarray(time_s, dtype=np.float64)
    y = np.asarray(series, dtype=np.float64)
    if t.shape[0] < MIN_SAMPLES + 2:
        return float("nan")
    k = _thinned(t.shape[0] - 2, 1)  # the middle epochs (every k-th past MAX_SAMPLES)
    h1 = t[k] - t[k - 1]
    h2 = t[k + 1] - t[k]
    ok = (h1 > 1e-9) & (h2 > 1e-9)
    span = np.where(ok, h1 + h2, 1.0)
    a = h2 / span  # weight of y_{k-1}
    b = h1 / span  # weight of y_{k+1}
    e = (y[k] - a * y[k - 1] - b * y[k + 1]) / np.sqrt(1.0 + a * a + b * b)
    return robust_sigma(np.where(ok, e, np.nan))


def pair_noise(
    time_s: FloatArray, range_m: FloatArray, di_m: FloatArray, white_m: float | None = None
) -> PairNoise:
    """White noise and growth of ``z = L - cumsum(I)`` (see the module docstring).

    ``white_m``: the white noise when the caller has it from elsewhere (local.py: from the
    ranges and the dead-reckoning DI, not from a DI that contains the cooperative
    solution); only the growth is then estimated here.

    sigma_w: the smaller of :func:`white_sigma` of the ranges alone and of z (the ranges
    alone are immune to DI faults, z to the pair's relative acceleration at low rates).
    q: the growth of the structure function to tau_2 = max(4 tau_1, 2 s) (tau_1 the median
    range interval) beyond the white part, (V(tau_2) - 2 sigma_w^2) / tau_2 >= 0: all of
    it is taken as DI random walk, which leans the filter on the ranges when the DI error
    grows faster than a random walk. Only differences whose actual lag is within a factor
    of two of tau_2 count (outages, two ranges at one time).
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.shape[0] < MIN_SAMPLES + 2:
        return PairNoise(float("nan"), float("nan"), 0)
    z = np.asarray(range_m, dtype=np.float64) - accumulated(di_m)
    if white_m is None:
        white = np.fmin(white_sigma(t, range_m), white_sigma(t, z))
    else:
        white = np.float64(white_m)
    dt = np.diff(t)
    dt = dt[dt > 1e-9]
    if not np.isfinite(white) or dt.shape[0] == 0:
        return PairNoise(float("nan"), float("nan"), 0)
    tau2 = max(4.0 * float(np.median(dt)), 2.0)
    v2, lag2, n2 = _lagged_variance(t, z, tau2)
    q = max((v2 - 2.0 * white * white) / lag2, 0.0) if np.isfinite(v2) else 0.0
    return PairNoise(float(white), float(q), n2)


def steady_gain(process_var: float, range_var: float) -> float:
    """Steady-state Kalman gain of a random walk with per-epoch process variance Q observed
    with noise variance R: P- = (Q + sqrt(Q^2 + 4 Q R)) / 2, K = P- / (P- + R). The filtered
    white noise keeps K of its variance: near 1, the DI adds nothing to the ranges."""
    if not (np.isfinite(process_var) and np.isfinite(range_var)) or range_var <= 0:
        return float("nan")
    q = max(process_var, 0.0)
    prior = 0.5 * (q + np.sqrt(q * q + 4.0 * q * range_var))
    return float(prior / (prior + range_var))
