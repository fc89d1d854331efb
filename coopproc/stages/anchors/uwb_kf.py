"""UWB-only positioning of a tag: robust LS fixes -> constant-velocity KF -> RTS smoother.

Paper 003 sec. 2.2 positions a UWB tag epoch by epoch by robust least squares (eq. (6)-
(12), :mod:`coopproc.stages.shared.lsq`); sec. 2.8 smooths with Rauch-Tung-Striebel.
This module filters one tag's fixes with a constant-velocity Kalman filter and smooths
the result, so that a platform without dead reckoning (role ``tag``) gets a trajectory
better than its raw fixes (methods ``lsq_kf`` and ``lsq_rts``, docs/methods-fusion.md).

Per axis (d = ``dims`` axes, state X = [p; v], 2d values):

    F = [[I, dt I], [0, I]]
    Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]    (white acceleration, PSD q)

Observations: the LS position with its covariance N^-1 (H = [I 0]) and, with
``kf_velocity``, the range-rate velocity with its covariance (H = [0 I]). Robust factor:
IGG-III (paper 002 eq. (18)) on each innovation standardized by sqrt(diag(H C H^T + R))
and by the MAD of the last ``MAD_WINDOW`` standardized innovations (eq. (19)-(20), floor
1, as the cooperative fusion); R_ij -> R_ij / sqrt(gamma_i gamma_j) as
:func:`coopproc.estimation.kalman.kf_update`. Update in Joseph form. The forward and
backward loops are compiled with numba.
"""

from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np

from coopproc.estimation.kalman import rts_backward_nb
from coopproc.estimation.linalg import cholesky_solve_nb
from coopproc.estimation.process_models import cv_transition
from coopproc.estimation.robust import igg3_scalar, mad_sigma_nb
from coopproc.model import FloatArray, Trajectory
from coopproc.stages.shared.lsq import LsqFixes, LsqParams

__all__ = ["MAD_WINDOW", "cv_filter", "cv_smooth", "uwb_kf_positions"]

#: Standardized innovations of earlier epochs pooled with the epoch's for the MAD.
MAD_WINDOW = 50
#: 1-sigma of the initial velocity when no velocity observation starts the filter, m/s.
V0_SIGMA_MPS = 2.0


@numba.njit(cache=True)
def _transition(dt: float, d: int, q: float) -> tuple[FloatArray, FloatArray]:
    return cv_transition(dt, np.full(d, q))  # the same PSD on every axis


@numba.njit(cache=True)
def _forward(
    t: FloatArray,
    z: FloatArray,
    r: FloatArray,
    use_v: np.ndarray,
    d: int,
    q: float,
    robust: bool,
    k0: float,
    k1: float,
    window: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    k_n = t.shape[0]
    n = 2 * d
    xf = np.zeros((k_n, n))
    cf = np.zeros((k_n, n, n))
    xp = np.zeros((k_n, n))
    cp = np.zeros((k_n, n, n))
    gam = np.ones((k_n, n))
    # start: the first fix, velocity from its observation or 0 +- V0_SIGMA
    x = np.zeros(n)
    c = np.zeros((n, n))
    for i in range(d):
        x[i] = z[0, i]
        for j in range(d):
            c[i, j] = r[0, i, j]
        if use_v[0]:
            x[d + i] = z[0, d + i]
            for j in range(d):
                c[d + i, d + j] = r[0, d + i, d + j]
        else:
            c[d + i, d + i] = V0_SIGMA_MPS**2
    xf[0], cf[0], xp[0], cp[0] = x, c, x, c
    hist = np.zeros(window)
    n_hist = 0
    for k in range(1, k_n):
        f, qm = _transition(t[k] - t[k - 1], d, q)
        x = f @ x
        c = f @ c @ f.T + qm
        xp[k], cp[k] = x, c
        m = n if use_v[k] else d
        h = np.zeros((m, n))
        for i in range(m):
            h[i, i] = 1.0
        rk = r[k, :m, :m].copy()
        v = z[k, :m] - h @ x
        hc = h @ c
        s_mat = hc @ h.T + rk
        g = np.ones(m)
        if robust:
            w = np.empty(m)
            for i in range(m):
                w[i] = v[i] / np.sqrt(s_mat[i, i])
            used = min(n_hist, window)
            pool = np.empty(used + m)
            pool[:used] = hist[:used]
            pool[used:] = w
            sigma = mad_sigma_nb(pool, np.ones(used + m), 1.0)
            for i in range(m):
                g[i] = igg3_scalar(w[i] / sigma, k0, k1)
                hist[n_hist % window] = w[i]
                n_hist += 1
            for i in range(m):
                for j in range(m):
                    rk[i, j] = rk[i, j] / np.sqrt(g[i] * g[j])
            s_mat = hc @ h.T + rk
        gain = cholesky_solve_nb(s_mat, hc).T  # C H^T S^-1
        x = x + gain @ v
        ikh = np.eye(n) - gain @ h
        c = ikh @ c @ ikh.T + gain @ rk @ gain.T  # Joseph form
        c = 0.5 * (c + c.T)
        xf[k], cf[k] = x, c
        gam[k, :m] = g
    return xf, cf, xp, cp, gam


@numba.njit(cache=True)
def _backward(
    t: FloatArray, xf: FloatArray, cf: FloatArray, xp: FloatArray, cp: FloatArray, d: int
) -> tuple[FloatArray, FloatArray]:
    """RTS (paper 003 sec. 2.8) with the constant-velocity transitions between ``t``."""
    fs = np.zeros((t.shape[0], 2 * d, 2 * d))
    for k in range(1, t.shape[0]):
        fs[k] = _transition(t[k] - t[k - 1], d, 0.0)[0]
    return rts_backward_nb(xf, cf, xp, cp, fs)


def _observations(fix: LsqFixes, use_velocity: bool) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """z (K, 2d), R (K, 2d, 2d) block-diagonal, and which epochs have a velocity."""
    k_n, d = fix.pos.shape
    z = np.zeros((k_n, 2 * d))
    r = np.zeros((k_n, 2 * d, 2 * d))
    z[:, :d] = fix.pos
    r[:, :d, :d] = fix.cov
    has_v = np.isfinite(fix.vel).all(axis=1) & np.isfinite(fix.vel_cov).all(axis=(1, 2))
    use_v = np.asarray(has_v & use_velocity, dtype=bool)
    z[use_v, d:] = fix.vel[use_v]
    r[use_v, d:, d:] = fix.vel_cov[use_v]
    return z, r, use_v


def cv_filter(
    fix: LsqFixes, params: LsqParams
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Forward constant-velocity KF over one tag's fixes: filtered X, C, predicted X, C
    and the robust factors (K, 2d) (module docstring)."""
    z, r, use_v = _observations(fix, params.kf_velocity)
    return _forward(  # type: ignore[no-any-return]
        np.ascontiguousarray(fix.time_s, dtype=np.float64),
        z,
        r,
        use_v,
        fix.pos.shape[1],
        float(params.kf_accel_psd),
        bool(params.kf_robust),
        float(params.kf_k0),
        float(params.kf_k1),
        MAD_WINDOW,
    )


def cv_smooth(fix: LsqFixes, params: LsqParams) -> tuple[FloatArray, FloatArray]:
    """Forward KF then RTS (paper 003 sec. 2.8): smoothed X (K, 2d) and C (K, 2d, 2d)."""
    xf, cf, xp, cp, _ = cv_filter(fix, params)
    t = np.ascontiguousarray(fix.time_s, dtype=np.float64)
    return _backward(t, xf, cf, xp, cp, fix.pos.shape[1])  # type: ignore[no-any-return]


def _trajectory(tid: str, fix: LsqFixes, x: FloatArray, c: FloatArray, source: str) -> Trajectory:
    d = fix.pos.shape[1]
    k_n = x.shape[0]
    enu = np.zeros((k_n, 3))
    sig = np.full((k_n, 3), np.nan)
    vel = np.zeros((k_n, 3))
    enu[:, :d] = x[:, :d]
    vel[:, :d] = x[:, d:]
    diag = np.sqrt(np.maximum(np.einsum("kii->ki", c), 0.0))
    sig[:, :d] = diag[:, :d]
    if d == 2:
        enu[:, 2] = fix.up
    return Trajectory(tid, fix.time_s, enu, sigma_enu_m=sig, vel_enu_mps=vel, source=source)


def uwb_kf_positions(
    fixes: Mapping[str, LsqFixes], params: LsqParams, *, smooth: bool
) -> Mapping[str, Trajectory]:
    """Every platform's fixes (:func:`coopproc.stages.anchors.anchor_lsq.anchor_fixes`)
    filtered (``smooth=False``, causal) or filtered and smoothed, at the fix epochs;
    platform id -> Trajectory with velocity."""
    out: dict[str, Trajectory] = {}
    for tid, fix in fixes.items():
        if smooth:
            x, c = cv_smooth(fix, params)
            out[tid] = _trajectory(tid, fix, x, c, "LSQ + constant-velocity KF + RTS")
        else:
            x, c, _, _, _ = cv_filter(fix, params)
            out[tid] = _trajectory(tid, fix, x, c, "LSQ + constant-velocity KF")
    return out
