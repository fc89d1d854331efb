"""Self-calibration of the ranging noise from the data (issue 10: the declared sigma is a prior).

Per pair, the ranges L_k and the distance increments I_k that drive the distance filter give
the series ``z_k = L_k - sum_{j <= k} I_j``: the (constant) initial distance plus the range
error minus the accumulated DI error. Its structure function

    V(tau) = E[(z(t + tau) - z(t))^2] = 2 sigma_w^2 + q tau  (+ higher order)

separates the white range noise sigma_w (the intercept) from everything that grows with the
lag: the random walk of the accumulated DI error and the slowly varying (coloured) part of
real UWB errors (multipath, antenna orientation). Both belong in the distance filter's
process noise: a DI that disagrees with the ranges beyond what the white noise explains is
leaned on less. V is estimated robustly ((1.4826 MAD)^2 of the lagged differences), so the
jumps at the edges of NLOS events (a minority of the differences) do not inflate it.

The innovation spread of the filter itself (residuals r = L - D' of eq. (9)) is the other
figure taken from the data: the detection threshold gamma_max of eq. (9) is gamma_sigma
times the robust spread of those residuals, combined with the declared sigma as a prior
(:func:`posterior_sigma`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.model import FloatArray

__all__ = ["MAD_SCALE", "PairNoise", "pair_noise", "posterior_sigma", "robust_sigma"]

MAD_SCALE = 1.4826
#: Fewer usable differences than this: no estimate (the caller keeps its prior).
MIN_SAMPLES = 20
#: Weight of a declared sigma, in epochs, when it is combined with a data estimate.
PRIOR_EPOCHS = 20.0


@dataclass(frozen=True)
class PairNoise:
    """What the data of one pair says about its noise (NaN: not enough data)."""

    white_sigma_m: float  # sigma_w, the white UWB noise (structure-function intercept)
    growth_m2ps: float  # q, growth of V(tau) per second: DI random walk + coloured range error
    samples: int  # lagged differences behind the estimate


def robust_sigma(values: FloatArray) -> float:
    """1.4826 MAD of the finite values (NaN when fewer than :data:`MIN_SAMPLES`)."""
    v = values[np.isfinite(values)]
    if v.shape[0] < MIN_SAMPLES:
        return float("nan")
    return MAD_SCALE * float(np.median(np.abs(v - np.median(v))))


def _lagged_variance(time_s: FloatArray, z: FloatArray, lag_s: float) -> tuple[float, float, int]:
    """Robust variance of z(t + lag) - z(t) over the epochs, and the mean actual lag."""
    j = np.searchsorted(time_s, time_s + lag_s - 1e-9)
    ok = j < time_s.shape[0]
    i = np.flatnonzero(ok)
    j = j[ok]
    d = z[j] - z[i]
    lag = time_s[j] - time_s[i]
    keep = np.isfinite(d) & (lag > 0) & (lag < 2.0 * lag_s + 1e-9)
    s = robust_sigma(d[keep])
    if not np.isfinite(s):
        return float("nan"), float("nan"), 0
    return s * s, float(np.mean(lag[keep])), int(np.count_nonzero(keep))


def pair_noise(time_s: FloatArray, range_m: FloatArray, di_m: FloatArray) -> PairNoise:
    """Structure-function fit of ``z = L - cumsum(I)`` (see the module docstring).

    Two lags: the pair's median range interval tau_1 and tau_2 = max(4 tau_1, 2 s).
    q = (V(tau_2) - V(tau_1)) / (tau_2 - tau_1) (>= 0), sigma_w^2 = (V(tau_1) - q tau_1) / 2.
    Epochs at one time (dt = 0) and restarts across outages are handled by the lag search:
    only differences whose actual lag is within a factor of two of the nominal one count.
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.shape[0] < MIN_SAMPLES + 1:
        return PairNoise(float("nan"), float("nan"), 0)
    inc = np.where(np.isfinite(di_m), di_m, 0.0)
    inc[0] = 0.0
    z = np.asarray(range_m, dtype=np.float64) - np.cumsum(inc)
    dt = np.diff(t)
    dt = dt[dt > 1e-9]
    if dt.shape[0] == 0:
        return PairNoise(float("nan"), float("nan"), 0)
    tau1 = float(np.median(dt))
    tau2 = max(4.0 * tau1, 2.0)
    v1, lag1, n1 = _lagged_variance(t, z, tau1)
    v2, lag2, _ = _lagged_variance(t, z, tau2)
    if not np.isfinite(v1):
        return PairNoise(float("nan"), float("nan"), 0)
    q = 0.0
    if np.isfinite(v2) and lag2 > lag1:
        q = max((v2 - v1) / (lag2 - lag1), 0.0)
    white = np.sqrt(max(v1 - q * lag1, 0.0) / 2.0)
    return PairNoise(float(white), float(q), n1)


def posterior_sigma(prior_m: float | None, estimate_m: float, samples: int) -> float:
    """The declared sigma (a prior worth :data:`PRIOR_EPOCHS` epochs) combined with a data
    estimate from ``samples`` epochs, on the variance: the data dominate long sessions.
    Without a prior the estimate; without an estimate the prior."""
    if not np.isfinite(estimate_m) or samples <= 0:
        return float(prior_m) if prior_m is not None else float("nan")
    if prior_m is None:
        return float(estimate_m)
    var = (PRIOR_EPOCHS * prior_m**2 + samples * estimate_m**2) / (PRIOR_EPOCHS + samples)
    return float(np.sqrt(var))
