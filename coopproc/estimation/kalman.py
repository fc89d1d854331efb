"""Linear Kalman building blocks: predict, (robust) update, one RTS step.

Dense numpy reference implementations, used directly for small problems and as the
known answer the compiled kernels are tested against. Notation follows paper 002
section 4.3: X state, C covariance, F transition, Q process noise, Z observations,
H design matrix, R observation covariance, V innovation, G gain, gamma robust factor
(:mod:`coopproc.estimation.robust`).
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.estimation.linalg import cholesky_solve_nb
from coopproc.model import FloatArray

__all__ = ["kf_predict", "kf_update", "rts_backward_nb", "rts_step"]


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
def rts_backward_nb(
    xf: FloatArray, cf: FloatArray, xp: FloatArray, cp: FloatArray, fs: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """:func:`rts_step` over a whole forward pass, compiled: filtered X, C (K, n), (K, n, n),
    predicted X, C and the transitions ``fs[k + 1]`` from k to k + 1; returns the smoothed
    X and C. The smoother of the anchors' and the odometer's linear filters; the INS
    error state (closed loop) and the cooperative fusion (checkpointed MBF) have their
    own forms of it (:mod:`coopproc.ins.smoother`, :mod:`coopproc.stages.fusion.smoother`).
    """
    k_n = xf.shape[0]
    xs = xf.copy()
    cs = cf.copy()
    for k in range(k_n - 2, -1, -1):
        a = cholesky_solve_nb(cp[k + 1], fs[k + 1] @ cf[k]).T  # C_k F^T (C^-_{k+1})^-1
        xs[k] = xf[k] + a @ (xs[k + 1] - xp[k + 1])
        ck = cf[k] + a @ (cs[k + 1] - cp[k + 1]) @ a.T
        cs[k] = 0.5 * (ck + ck.T)
    return xs, cs
