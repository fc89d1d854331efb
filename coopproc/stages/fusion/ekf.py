"""Compiled per-epoch loops of the cooperative EKF and its RTS smoother.

The state is the stacked position of every moving platform, ``dim`` (2 or 3) values per
platform: index ``p * dim + axis``. The transition is the identity plus the platforms'
dead-reckoning increments as control input (F = I, X_k = X_{k-1} + u_k), the process
noise diagonal ``q`` (paper 002 eq. (12)-(13)). Observations of one epoch are processed
as one batch EKF update (eq. (14)-(17)), carried out as scalar updates whose innovations
are corrected for the state change of the earlier ones (exactly the batch update for a
diagonal R), so no matrix is inverted and the cost is O(m n^2) per epoch.

Observation kinds (``obs_kind``):

- ``OBS_RANGE`` (0): range between moving platforms ``a`` and ``b``, |X_a - X_b - o| with
  ``o = obs_anchor`` the difference of their dead-reckoning motion from the epoch time to
  the range's own time (0 when the range is at the epoch time);
- ``OBS_ANCHOR`` (1): range between moving platform ``a`` and the fixed point ``anchor``
  (the anchor minus a's dead-reckoning motion from the epoch time to the range time);
- ``OBS_POSITION`` (2): coordinate ``b`` (axis) of platform ``a`` (a leader's own fix).

With ``dim == 2`` the range model is sqrt(de^2 + dn^2 + dz2) where ``dz2`` is the squared
height difference taken from the navigation (or the anchor's height); with ``dim == 3``
``dz2`` is 0 and the height is estimated.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray
from coopproc.stages.filters import cholesky_solve_nb, igg3_scalar, mad_sigma_nb

__all__ = ["OBS_ANCHOR", "OBS_POSITION", "OBS_RANGE", "ekf_forward", "rts_backward"]

#: Epochs with this many observations or more take eq. (20)'s MAD over their own
#: innovations; fewer are pooled with the last ``mad_window`` ones.
MAD_EPOCH_MIN = 8

OBS_RANGE = 0
OBS_ANCHOR = 1
OBS_POSITION = 2

IntArray = NDArray[np.int64]


@numba.njit(cache=True)
def _observe(
    x: FloatArray,
    kind: int,
    a: int,
    b: int,
    anchor: FloatArray,
    dz2: float,
    dim: int,
    idx: IntArray,
    val: FloatArray,
) -> tuple[float, int]:
    """Predicted observation h(X) and its sparse Jacobian row (indices, values, count)."""
    if kind == OBS_POSITION:
        idx[0] = a * dim + b
        val[0] = 1.0
        return x[a * dim + b], 1
    sq = dz2
    for ax in range(dim):
        if kind == OBS_RANGE:
            diff = x[a * dim + ax] - x[b * dim + ax] - anchor[ax]
        else:
            diff = x[a * dim + ax] - anchor[ax]
        val[ax] = diff
        sq += diff * diff
    rho = np.sqrt(max(sq, 1e-12))
    count = 0
    for ax in range(dim):
        unit = val[ax] / rho  # d rho / d x_a = (x_a - x_b) / rho
        idx[count] = a * dim + ax
        val[count] = unit
        count += 1
    if kind == OBS_RANGE:
        for ax in range(dim):
            idx[count] = b * dim + ax
            val[count] = -val[ax]
            count += 1
    return rho, count


@numba.njit(cache=True)
def ekf_forward(
    x0: FloatArray,
    c0: FloatArray,
    u: FloatArray,
    q: FloatArray,
    obs_ptr: IntArray,
    obs_kind: IntArray,
    obs_a: IntArray,
    obs_b: IntArray,
    obs_anchor: FloatArray,
    obs_dz2: FloatArray,
    z: FloatArray,
    r_var: FloatArray,
    dim: int,
    robust: bool,
    k0: float,
    k1: float,
    sigma_floor: float,
    keep_cov: bool,
    mad_window: int = 0,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Forward EKF over K epochs.

    ``mad_window``: the MAD unit-weight sigma of eq. (20) of an epoch with fewer than
    :data:`MAD_EPOCH_MIN` observations is taken over its innovations together with the last
    ``mad_window`` standardized innovations of earlier epochs (0: the epoch's alone, as
    paper 002 writes it for many satellites per epoch, which larger epochs keep).
    With one range per epoch (staggered UWB polling) the epoch-only MAD is |v| / sqrt(d)
    itself, every standardized innovation is 1 and the robust factor never acts.

    Returns the filtered states (K, n), their variances (K, n), the filtered covariances
    (K, n, n) when ``keep_cov`` (else (1, n, n)), the robust factor of every observation
    (M,), its innovation at the prior (M,) and that innovation's variance H C H^T + R (M,).
    """
    n_epochs = u.shape[0]
    n = x0.shape[0]
    n_obs = z.shape[0]
    xs = np.empty((n_epochs, n))
    var = np.empty((n_epochs, n))
    covs = np.empty((n_epochs if keep_cov else 1, n, n))
    gamma = np.ones(n_obs)
    innov = np.zeros(n_obs)
    innov_var = np.zeros(n_obs)
    x = x0.copy()
    c = c0.copy()
    width = 2 * dim
    max_m = 0
    for k in range(n_epochs):
        max_m = max(max_m, obs_ptr[k + 1] - obs_ptr[k])
    h_idx = np.zeros((max(max_m, 1), width), dtype=np.int64)
    h_val = np.zeros((max(max_m, 1), width))
    h_cnt = np.zeros(max(max_m, 1), dtype=np.int64)
    v = np.zeros(max(max_m, 1))
    d = np.zeros(max(max_m, 1))
    ph = np.zeros(n)
    x_prior = np.zeros(n)
    ring = np.zeros(max(mad_window, 1))
    ring_n = 0
    ring_at = 0
    pool = np.zeros(max(mad_window, 1) + max(max_m, 1))
    ones = np.ones(max(mad_window, 1) + max(max_m, 1))
    for k in range(n_epochs):
        if k > 0:  # time update, paper 002 eq. (12)-(13) with F = I
            for i in range(n):
                x[i] += u[k, i]
                c[i, i] += q[k, i]
        lo = obs_ptr[k]
        m = obs_ptr[k + 1] - lo
        # innovations at the prior and their variances d = H C H^T + R, eq. (14), (19)
        for j in range(m):
            o = lo + j
            pred, cnt = _observe(
                x, obs_kind[o], obs_a[o], obs_b[o], obs_anchor[o], obs_dz2[o], dim,
                h_idx[j], h_val[j],
            )  # fmt: skip
            h_cnt[j] = cnt
            v[j] = z[o] - pred
            hch = 0.0
            for p in range(cnt):
                for s in range(cnt):
                    hch += h_val[j, p] * c[h_idx[j, p], h_idx[j, s]] * h_val[j, s]
            d[j] = hch + r_var[o]
            innov[o] = v[j]
            innov_var[o] = d[j]
        if robust and m > 0 and (mad_window <= 0 or m >= MAD_EPOCH_MIN):
            # eq. (20) -> (19) -> (18) over the epoch's own innovations
            sigma = mad_sigma_nb(v[:m], d[:m], sigma_floor)
        elif robust and m > 0:  # too few for a median: the epoch and the recent window
            used = 0
            for j in range(m):
                pool[used] = abs(v[j]) / np.sqrt(d[j])
                used += 1
            for j in range(ring_n):
                pool[used] = ring[j]
                used += 1
            sigma = mad_sigma_nb(pool[:used], ones[:used], sigma_floor)
        if robust and m > 0:
            for j in range(m):
                gamma[lo + j] = igg3_scalar(v[j] / (sigma * np.sqrt(d[j])), k0, k1)
                if mad_window > 0:
                    ring[ring_at] = abs(v[j]) / np.sqrt(d[j])
                    ring_at = (ring_at + 1) % mad_window
                    ring_n = min(ring_n + 1, mad_window)
        for i in range(n):
            x_prior[i] = x[i]
        for j in range(m):  # batch update eq. (15)-(17) as corrected scalar updates
            o = lo + j
            cnt = h_cnt[j]
            vj = v[j]
            for p in range(cnt):
                vj -= h_val[j, p] * (x[h_idx[j, p]] - x_prior[h_idx[j, p]])
            for i in range(n):
                acc = 0.0
                for p in range(cnt):
                    acc += c[i, h_idx[j, p]] * h_val[j, p]
                ph[i] = acc
            s_var = r_var[o] / gamma[o]  # R / gamma, eq. (16)
            for p in range(cnt):
                s_var += h_val[j, p] * ph[h_idx[j, p]]
            for i in range(n):
                x[i] += ph[i] / s_var * vj
            for i in range(n):
                gi = ph[i] / s_var
                for jj in range(n):
                    c[i, jj] -= gi * ph[jj]
        for i in range(n):
            for jj in range(i + 1, n):
                sym = 0.5 * (c[i, jj] + c[jj, i])
                c[i, jj] = sym
                c[jj, i] = sym
            xs[k, i] = x[i]
            var[k, i] = c[i, i]
        if keep_cov:
            covs[k] = c
    return xs, var, covs, gamma, innov, innov_var


@numba.njit(cache=True)
def rts_backward(
    xs_f: FloatArray, covs_f: FloatArray, u: FloatArray, q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """RTS fixed-interval smoother (paper 003 section 2.8) for F = I.

    With X^-_{k+1} = X_k + u_{k+1} and C^-_{k+1} = C_k + Q_{k+1}:
    A_k = C_k (C^-_{k+1})^-1, X^s_k = X_k + A_k (X^s_{k+1} - X^-_{k+1}),
    C^s_k = C_k + A_k (C^s_{k+1} - C^-_{k+1}) A_k^T. Returns states and variances (K, n).
    """
    n_epochs, n = xs_f.shape
    xs = np.empty((n_epochs, n))
    var = np.empty((n_epochs, n))
    x_next = xs_f[n_epochs - 1].copy()
    c_next = covs_f[n_epochs - 1].copy()
    xs[n_epochs - 1] = x_next
    for i in range(n):
        var[n_epochs - 1, i] = c_next[i, i]
    c_pred = np.empty((n, n))
    for k in range(n_epochs - 2, -1, -1):
        c_f = covs_f[k]
        for i in range(n):
            for jj in range(n):
                c_pred[i, jj] = c_f[i, jj]
            c_pred[i, i] += q[k + 1, i]
        # A^T = (C^-)^-1 C_k since both are symmetric
        a_t = cholesky_solve_nb(c_pred, c_f)
        dx = np.empty(n)
        for i in range(n):
            dx[i] = x_next[i] - (xs_f[k, i] + u[k + 1, i])
        x_s = np.empty(n)
        for i in range(n):
            acc = xs_f[k, i]
            for jj in range(n):
                acc += a_t[jj, i] * dx[jj]
            x_s[i] = acc
        dc = c_next - c_pred
        tmp = a_t.T @ dc
        c_s = c_f + tmp @ a_t
        for i in range(n):
            for jj in range(i + 1, n):
                sym = 0.5 * (c_s[i, jj] + c_s[jj, i])
                c_s[i, jj] = sym
                c_s[jj, i] = sym
        xs[k] = x_s
        for i in range(n):
            var[k, i] = c_s[i, i]
        x_next = x_s
        c_next = c_s
    return xs, var
