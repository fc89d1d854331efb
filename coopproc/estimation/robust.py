"""The IGG-III robust update and the MAD unit-weight sigma (paper 002 eq. (18)-(20)).

Two flavours of each formula: numpy functions on arrays (``igg3_factor``, ``mad_sigma``,
``robust_factors``), the reference the compiled kernels are tested against, and numba
scalar helpers (``igg3_scalar``, ``mad_sigma_nb``) called inside compiled per-epoch loops
of the fusion, anchor, odometer and INS filters.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = [
    "GAMMA_REJECT",
    "MAD_SCALE",
    "igg3_factor",
    "igg3_scalar",
    "mad_sigma",
    "mad_sigma_nb",
    "robust_factors",
    "standardized_innovation",
]

#: gamma for |s| > k1 (paper 002 eq. (18)): the observation's variance becomes R / 1e-30.
GAMMA_REJECT = 1e-30
#: Consistency constant of the median absolute deviation for Gaussian noise, eq. (20).
MAD_SCALE = 1.4826


def igg3_factor(s: FloatArray | float, k0: float, k1: float) -> FloatArray:
    """IGG-III robust factor, paper 002 eq. (18), of standardized innovations ``s``.

    gamma = 1 for |s| <= k0; (k0/|s|) ((k1-|s|)/(k1-k0))^2 for k0 < |s| <= k1;
    1e-30 beyond k1. The paper writes s_k; innovations are signed, so |s_k| is meant.
    The middle branch reaches 0 at |s| = k1; it is floored at 1e-30 (the value beyond
    k1) so that R / gamma stays finite.
    """
    a = np.abs(np.asarray(s, dtype=np.float64))
    mid = np.maximum((k0 / np.maximum(a, 1e-300)) * ((k1 - a) / (k1 - k0)) ** 2, GAMMA_REJECT)
    return np.where(a <= k0, 1.0, np.where(a <= k1, mid, GAMMA_REJECT))


def mad_sigma(v: FloatArray, d: FloatArray, floor: float = 0.0) -> float:
    """Robust unit-weight sigma, paper 002 eq. (20): 1.4826 median(|V| / sqrt(d)).

    ``d`` is the reciprocal weight (variance factor) of each innovation. The result is
    raised to ``floor`` when smaller (see ``robust_factors``).
    """
    if v.shape[0] == 0:
        return float(floor)
    sigma = MAD_SCALE * float(np.median(np.abs(v) / np.sqrt(d)))
    return max(sigma, floor)


def standardized_innovation(v: FloatArray, d: FloatArray, sigma: float) -> FloatArray:
    """s = V / (sigma sqrt(d)), paper 002 eq. (19)."""
    return np.asarray(v / (sigma * np.sqrt(d)), dtype=np.float64)


def robust_factors(
    v: FloatArray, d: FloatArray, k0: float, k1: float, sigma_floor: float = 1.0
) -> FloatArray:
    """gamma of each innovation of one epoch: eq. (20) -> eq. (19) -> eq. (18).

    ``d`` is the innovation variance diag(H C H^T + R), so the a-priori unit-weight sigma
    is 1; the MAD estimate is floored at ``sigma_floor`` (default 1) so that it can only
    widen the acceptance band when the innovations are larger than their model says, and
    a small epoch (one or two ranges) is still tested against its predicted variance.
    """
    sigma = mad_sigma(v, d, sigma_floor)
    return igg3_factor(standardized_innovation(v, d, sigma), k0, k1)


@numba.njit(cache=True)
def igg3_scalar(s: float, k0: float, k1: float) -> float:
    """IGG-III factor of one standardized innovation (compiled), paper 002 eq. (18)."""
    a = abs(s)
    if a <= k0:
        return 1.0
    if a <= k1:
        t = (k1 - a) / (k1 - k0)
        return max((k0 / a) * t * t, GAMMA_REJECT)
    return GAMMA_REJECT


@numba.njit(cache=True)
def mad_sigma_nb(v: FloatArray, d: FloatArray, floor: float) -> float:
    """Compiled :func:`mad_sigma`, paper 002 eq. (20)."""
    m = v.shape[0]
    if m == 0:
        return floor
    w = np.empty(m)
    for i in range(m):
        w[i] = abs(v[i]) / np.sqrt(d[i])
    sigma = MAD_SCALE * np.median(w)
    return max(sigma, floor)
