"""The range-step test: does the ranges' own step confirm an NLOS onset?

NLOS lengthens the ranges themselves at its onset; a dead-reckoning fault (wheel slip,
heading jump) moves the DI-propagated distance of the filter (paper 000 eq. (8)) and leaves
the ranges smooth, so the same eq. (9) residual shows no step in the ranges alone.
:func:`range_jump` fits that step by least squares; :func:`steps_up` is the test the
distance filter (:mod:`coopproc.stages.ranging.nlos_kernel`) applies to a suspect epoch.
Compiled (Numba), called from inside the filter's compiled loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from coopproc.model import FloatArray

__all__ = ["JUMP_MIN_POINTS", "range_jump", "steps_up"]


#: Ranges on each side of a step test at least (at 1 Hz, 5 s gave the step a 1-sigma of
#: 1.3 x the range noise; 10 ranges, 0.9 x).
JUMP_MIN_POINTS = 10


@njit(cache=True)
def range_jump(t: FloatArray, rng: FloatArray, k: int, window_s: float) -> tuple[float, float]:
    """The step of the ranges alone at epoch ``k``.

    Least squares of the ranges within ``window_s`` seconds (and at least
    :data:`JUMP_MIN_POINTS` ranges) either side of t_k on a line with one slope and a step
    J at t_k, y = a + b (t - t_k) + J [t >= t_k]; returns J and its variance factor
    (var / sigma^2). NaN without 2+ points on each side. NLOS lengthens the ranges
    themselves at its onset; a dead-reckoning fault (wheel slip, heading jump) moves the
    DI-propagated distance and leaves the ranges smooth, so the same residual of eq. (9)
    shows no step here.
    """
    n = t.shape[0]
    lo = k
    while lo - 1 >= 0 and (t[k] - t[lo - 1] <= window_s or k - lo < JUMP_MIN_POINTS):
        lo -= 1
    hi = k
    while hi < n and (t[hi] - t[k] < window_s or hi - k < JUMP_MIN_POINTS):
        hi += 1
    if k - lo < 2 or hi - k < 2:
        return np.nan, np.inf
    # normal equations of [1, x = t - t_k, step] (3 x 3), solved for the step by Cramer's
    # rule (no LAPACK call: this runs at every suspect epoch)
    s0 = s1 = s2 = s11 = s12 = s22 = y0 = y1 = y2 = 0.0
    for j in range(lo, hi):
        if not np.isfinite(rng[j]):
            continue  # a rejected range (outliers.py)
        x = t[j] - t[k]
        z = 1.0 if j >= k else 0.0
        y = rng[j]
        s0 += 1.0
        s1 += x
        s2 += z
        s11 += x * x
        s12 += x * z
        s22 += z * z
        y0 += y
        y1 += x * y
        y2 += z * y
    det = s0 * (s11 * s22 - s12 * s12) - s1 * (s1 * s22 - s12 * s2) + s2 * (s1 * s12 - s11 * s2)
    if abs(det) < 1e-12:
        return np.nan, np.inf
    num = s0 * (s11 * y2 - y1 * s12) - s1 * (s1 * y2 - y1 * s2) + y0 * (s1 * s12 - s11 * s2)
    return num / det, (s0 * s11 - s1 * s1) / det


@njit(cache=True)
def steps_up(
    t: FloatArray, rng: FloatArray, k: int, amount: float, fraction: float, window_s: float
) -> bool:
    """True when the ranges alone step at epoch ``k`` by at least ``fraction * amount``
    (:func:`range_jump`), or when the test is off or cannot be made.

    For a positive residual (NLOS lengthens ranges) the ranges must step up. A negative
    residual passes unless the ranges step down by more than ``fraction * |amount|``: a
    step down is the end of a lengthening the filter had absorbed, used as line of sight
    at once; a negative residual without a step goes on to detection, where
    ``positive_only`` re-anchors the distance on the ranges (measured on TIERS: requiring
    a step down in the direction of a negative residual instead flagged 57 % of the
    line-of-sight epochs of tb4-tb7).
    """
    if fraction <= 0.0:
        return True
    jump, _ = range_jump(t, rng, k, window_s)
    return not np.isfinite(jump) or jump >= fraction * amount
