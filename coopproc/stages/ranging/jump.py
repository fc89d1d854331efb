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

from coopproc.estimation.robust import MAD_SCALE
from coopproc.model import FloatArray

__all__ = [
    "FIT_ADEQUACY",
    "JUMP_MIN_POINTS",
    "LEVEL_OUTLIER_SIGMAS",
    "STEP_SIGNIFICANCE",
    "level_step",
    "range_jump",
    "step_fit",
    "steps_up",
]


#: Ranges on each side of a step test at least (at 1 Hz, 5 s gave the step a 1-sigma of
#: 1.3 x the range noise; 10 ranges, 0.9 x).
JUMP_MIN_POINTS = 10


@njit(cache=True)
def _fit_extent(t: FloatArray, k: int, window_s: float) -> tuple[int, int]:
    """[lo, hi) of the epochs a step test at ``k`` fits: ``window_s`` seconds (and at
    least :data:`JUMP_MIN_POINTS` epochs) either side of t_k."""
    n = t.shape[0]
    lo = k
    while lo - 1 >= 0 and (t[k] - t[lo - 1] <= window_s or k - lo < JUMP_MIN_POINTS):
        lo -= 1
    hi = k
    while hi < n and (t[hi] - t[k] < window_s or hi - k < JUMP_MIN_POINTS):
        hi += 1
    return lo, hi


@njit(cache=True)
def _line_step(
    t: FloatArray, rng: FloatArray, lo: int, hi: int, k: int
) -> tuple[float, float, float, float]:
    """(J, its variance factor, a, b) of the least-squares fit y = a + b (t - t_k) +
    J [t >= t_k] to the finite values of ``rng[lo:hi]``; J NaN when it cannot be fitted."""
    # normal equations of [1, x = t - t_k, step] (3 x 3), solved by Cramer's rule (no
    # LAPACK call: this runs at every suspect epoch)
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
        return np.nan, np.inf, np.nan, np.nan
    num = s0 * (s11 * y2 - y1 * s12) - s1 * (s1 * y2 - y1 * s2) + y0 * (s1 * s12 - s11 * s2)
    jump = num / det
    # a and b from the first two normal equations with J known
    rhs0 = y0 - s2 * jump
    rhs1 = y1 - s12 * jump
    det2 = s0 * s11 - s1 * s1
    if abs(det2) < 1e-12:
        return jump, (s0 * s11 - s1 * s1) / det, np.nan, np.nan
    a = (rhs0 * s11 - s1 * rhs1) / det2
    b = (s0 * rhs1 - s1 * rhs0) / det2
    return jump, (s0 * s11 - s1 * s1) / det, a, b


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
    lo, hi = _fit_extent(t, k, window_s)
    if k - lo < 2 or hi - k < 2:
        return np.nan, np.inf
    jump, var, _, _ = _line_step(t, rng, lo, hi, k)
    return jump, var


#: :func:`level_step` leaves out of its second fit the values whose residual from the
#: first is beyond this many robust sigmas (MAD_SCALE x the median absolute residual): the
#: 3 sigma of eq. (9).
LEVEL_OUTLIER_SIGMAS = 3.0


@njit(cache=True)
def level_step(t: FloatArray, y: FloatArray, k: int, window_s: float) -> tuple[float, float]:
    """:func:`range_jump` of a level series (the ranges less the summed increments) that
    one value cannot make: fitted, its values beyond :data:`LEVEL_OUTLIER_SIGMAS` robust
    sigmas of the residuals left out, fitted again.

    A step backed by the ranges is a change of their level, not one range: a single range
    1.4 m long just before t_k (real MiLUV ranges, 0.8 Hz, an outlier the range series'
    motion gate let through, docs/methods-ranging.md) made the plain fit's step -0.65 m
    against -0.10 m without it. The step is fitted at the epoch's own time whether or not
    its value is left out.
    """
    lo, hi = _fit_extent(t, k, window_s)
    if k - lo < 2 or hi - k < 2:
        return np.nan, np.inf
    jump, var, a, b = _line_step(t, y, lo, hi, k)
    if not (np.isfinite(jump) and np.isfinite(a) and np.isfinite(b)):
        return jump, var
    res = np.full(hi - lo, np.nan)
    for j in range(lo, hi):
        if np.isfinite(y[j]):
            z = 1.0 if j >= k else 0.0
            res[j - lo] = y[j] - (a + b * (t[j] - t[k]) + jump * z)
    finite = res[np.isfinite(res)]
    if finite.shape[0] == 0:
        return jump, var
    scale = MAD_SCALE * np.median(np.abs(finite))
    if not scale > 0.0:
        return jump, var
    kept = y[lo:hi].copy()
    dropped = 0
    for j in range(hi - lo):
        if np.isfinite(res[j]) and abs(res[j]) > LEVEL_OUTLIER_SIGMAS * scale:
            kept[j] = np.nan
            dropped += 1
    if dropped == 0:
        return jump, var
    tt = t[lo:hi]
    before = 0
    after = 0
    for j in range(hi - lo):
        if np.isfinite(kept[j]):
            if lo + j < k:
                before += 1
            else:
                after += 1
    if before < 2 or after < 2:
        return jump, var
    jump2, var2, _, _ = _line_step(tt, kept, 0, hi - lo, k - lo)
    return jump2, var2


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


#: A ranges-only step (:func:`step_fit`) is NLOS when it is at least this many of its
#: standard errors. The misfit of a local quadratic to a moving pair's ranges is coloured,
#: so the nominal 3 sigma of eq. (9) is not 3 sigma here: on the real `tuc` session (a
#: turning robot, 2 Hz ranges, no usable DI) 8-17 % of the line-of-sight epochs step by
#: more than 3 standard errors and none by more than 5.
STEP_SIGNIFICANCE = 5.0
#: ... and when the fit follows the ranges: its residual 1-sigma at most this many of the
#: window's white range noise. Where a quadratic cannot follow the motion (real `plaza2`: a
#: robot turning at 1 m/s, 1.2 Hz ranges, residuals of metres) a "step" of 5-9 m at 5
#: standard errors is the misfit, not NLOS: there the ranges alone cannot tell.
FIT_ADEQUACY = 3.0


@njit(cache=True)
def _quadratic_step(
    t: FloatArray, y: FloatArray, lo: int, hi: int, k: int
) -> tuple[float, float, float]:
    """(J, its standard error, residual variance) of y on a + b x + c x^2 + J [t >= t_k]."""
    rows = 0
    before = 0
    for j in range(lo, hi):
        if np.isfinite(y[j]):
            rows += 1
            if j < k:
                before += 1
    if before < 3 or rows - before < 3 or rows < 8:
        return np.nan, np.inf, np.inf
    a = np.empty((rows, 4))
    z = np.empty(rows)
    m = 0
    for j in range(lo, hi):
        if not np.isfinite(y[j]):
            continue
        x = t[j] - t[k]
        a[m, 0] = 1.0
        a[m, 1] = x
        a[m, 2] = x * x
        a[m, 3] = 1.0 if j >= k else 0.0
        z[m] = y[j]
        m += 1
    normal = a.T @ a
    if abs(np.linalg.det(normal)) < 1e-12:
        return np.nan, np.inf, np.inf
    inv = np.linalg.inv(normal)
    coef = inv @ (a.T @ z)
    e = z - a @ coef
    s2 = max(float(e @ e) / (rows - 4), 0.0)
    return coef[3], np.sqrt(s2 * inv[3, 3]), s2


@njit(cache=True)
def step_fit(
    t: FloatArray, rng: FloatArray, motion: FloatArray, k: int, window_s: float
) -> tuple[float, float, float]:
    """The ranges' own step at epoch ``k``, its standard error and the fit's residual
    1-sigma, without the DI filter.

    Least squares within ``window_s`` seconds (and at least :data:`JUMP_MIN_POINTS` ranges)
    either side of t_k on a quadratic with a step J at t_k, y = a + b x + c x^2 +
    J [t >= t_k] (x = t - t_k: a pair's relative acceleration is absorbed), the standard
    error from the fit's own residuals; y is the ranges, or the ranges less ``motion``
    (the accumulated dead-reckoning DI), whichever the quadratic fits better: a usable
    dead reckoning removes the motion a quadratic cannot follow (exact simulated ranges:
    the estimate of a 0.5 m step 0.425 m on the ranges, 0.491 m less the motion), a poor
    one adds errors (real `plaza2`, heading off by up to 120 deg: metre "steps"). Used
    where the DI cannot smooth (local.py ranges-only windows). (NaN, inf, inf) without 3+
    ranges on each side.
    """
    lo, hi = _fit_extent(t, k, window_s)
    j1, se1, s1 = _quadratic_step(t, rng, lo, hi, k)
    j2, se2, s2 = _quadratic_step(t, rng - motion, lo, hi, k)
    if s2 < s1:
        return j2, se2, np.sqrt(s2)
    return j1, se1, np.sqrt(s1)
