"""Shared Kalman-filter building blocks: predict, (robust) update, IGG-III, MAD, RTS.

Written once and used by the fusion stage (and by anyone who needs a plain or robust
Kalman filter). Two flavours of each formula:

- numpy functions on dense arrays (``kf_predict``, ``kf_update``, ``igg3_factor``,
  ``mad_sigma``, ``rts_step``): clear reference implementations, used directly for small
  problems and as the known answer the compiled kernels are tested against;
- numba scalar/array helpers (``igg3_scalar``, ``mad_sigma_nb``, ``cholesky_solve_nb``)
  used inside compiled per-epoch loops.

Notation follows paper 002 section 4.3: X state, C covariance, F transition, Q process
noise, Z observations, H design matrix, R observation covariance, V innovation, G gain,
gamma robust factor.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = [
    "GAMMA_REJECT",
    "MAD_SCALE",
    "cholesky_solve_nb",
    "igg3_factor",
    "igg3_scalar",
    "kf_predict",
    "kf_update",
    "mad_sigma",
    "mad_sigma_nb",
    "robust_factors",
    "rts_step",
    "standardized_innovation",
]

#: gamma for |s| > k1 (paper 002 eq. (18)): the observation's variance becomes R / 1e-30.
GAMMA_REJECT = 1e-30
#: Consistency constant of the median absolute deviation for Gaussian noise, eq. (20).
MAD_SCALE = 1.4826


def kf_predict(
    x: FloatArray, c: FloatArray, f: FloatArray, q: FloatArray, u: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Time update, paper 002 eq. (12)-(13): X = F X (+ u), C = F C F^T + Q.

    ``u`` is an optional control input (e.g. dead-reckoning increments) added to F X.
    """
    x_pred = f @ x
    if u is not None:
        x_pred = x_pred + u
    c_pred = f @ c @ f.T + q
    return x_pred, 0.5 * (c_pred + c_pred.T)


def kf_update(
    x: FloatArray,
    c: FloatArray,
    v: FloatArray,
    h: FloatArray,
    r: FloatArray,
    gamma: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Observation update with robust factors, paper 002 eq. (14)-(17).

    Parameters
    ----------
    x, c : prior state (n,) and covariance (n, n).
    v : innovation Z - h(X) (m,), eq. (14).
    h : design matrix (m, n).
    r : observation covariance, (m, m) or its diagonal (m,).
    gamma : robust factor per observation (m,), eq. (18); None means all 1. It scales the
        observation variances as R / gamma in the gain, eq. (16).
    """
    r_mat = np.diag(r) if r.ndim == 1 else r.copy()
    if gamma is not None:
        scale = 1.0 / np.sqrt(gamma)
        r_mat = r_mat * np.outer(scale, scale)  # diag R -> R / gamma, eq. (16)
    s = h @ c @ h.T + r_mat
    g = np.linalg.solve(s, h @ c).T  # G = C H^T S^-1 (S and C symmetric), eq. (16)
    x_new = x + g @ v  # eq. (15)
    c_new = (np.eye(x.shape[0]) - g @ h) @ c  # eq. (17)
    return x_new, 0.5 * (c_new + c_new.T)


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


def rts_step(
    x_f: FloatArray,
    c_f: FloatArray,
    x_p_next: FloatArray,
    c_p_next: FloatArray,
    x_s_next: FloatArray,
    c_s_next: FloatArray,
    f_next: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """One backward Rauch-Tung-Striebel step (paper 003 section 2.8).

    A_k = C_k F^T (C^-_{k+1})^-1; X^s_k = X_k + A_k (X^s_{k+1} - X^-_{k+1});
    C^s_k = C_k + A_k (C^s_{k+1} - C^-_{k+1}) A_k^T, where X_k, C_k are the forward
    (filtered) estimate at k and X^-_{k+1}, C^-_{k+1} the forward prediction to k+1.
    """
    a = np.linalg.solve(c_p_next, f_next @ c_f).T
    x_s = x_f + a @ (x_s_next - x_p_next)
    c_s = c_f + a @ (c_s_next - c_p_next) @ a.T
    return x_s, 0.5 * (c_s + c_s.T)


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


@numba.njit(cache=True)
def cholesky_solve_nb(a: FloatArray, b: FloatArray) -> FloatArray:
    """X with A X = B for symmetric positive definite A (n, n) and B (n, m), compiled."""
    n = a.shape[0]
    low = np.zeros((n, n))
    for j in range(n):
        acc = a[j, j]
        for k in range(j):
            acc -= low[j, k] * low[j, k]
        low[j, j] = np.sqrt(max(acc, 1e-300))
        for i in range(j + 1, n):
            acc = a[i, j]
            for k in range(j):
                acc -= low[i, k] * low[j, k]
            low[i, j] = acc / low[j, j]
    m = b.shape[1]
    x = np.empty((n, m))
    for col in range(m):
        y = np.empty(n)
        for i in range(n):
            acc = b[i, col]
            for k in range(i):
                acc -= low[i, k] * y[k]
            y[i] = acc / low[i, i]
        for i in range(n - 1, -1, -1):
            acc = y[i]
            for k in range(i + 1, n):
                acc -= low[k, i] * x[k, col]
            x[i, col] = acc / low[i, i]
    return x
