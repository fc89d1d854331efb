"""Rauch-Tung-Striebel smoothing over the full error state of the closed-loop INS filter
(paper 003 section 2.8; docs/methods-ins.md, "RTS smoother"), numba-compiled.

The forward filter (:func:`coopproc.ins.kernels.forward` or the plain
:func:`coopproc.ins.loop.run_events`) feeds every estimate back, so its error state is
zero after each propagation epoch and its prediction is zero too. Per epoch j it keeps
the filtered covariance P_j, the estimate x_j it fed back, and the inputs of the block's
Phi (rebuilt here, so Phi and P^-_{j+1} = Phi P_j Phi^T + Q are not stored). The smoothed
error dx^s_j of the filtered (corrected) nav at epoch j:

    C_j = P_j Phi_{j+1}^T (P^-_{j+1})^-1
    dx^s_j = C_j (dx^s_{j+1} + x_{j+1})
    P^s_j = P_j + C_j (P^s_{j+1} - P^-_{j+1}) C_j^T,      dx^s_J = 0, P^s_J = P_J

(the error-state RTS with reset: x_{j+1} + dx^s_{j+1} is the smoothed error of the
predicted nav at j+1, which the filter corrected by x_{j+1}). Between epochs the
correction is interpolated linearly in time, from dx^s_j at k_j to dx^s_{j+1} + x_{j+1}
just before k_{j+1}, and applied to the filtered nav of every IMU sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from coopproc.estimation.linalg import cholesky_solve_nb
from coopproc.ins.loop import ForwardRun
from coopproc.ins.models import ImuFigures
from coopproc.ins.propagation import apply_correction_nb, continuous_noise, phi_q, propagate_cov
from coopproc.model import FloatArray

__all__ = ["Smoothed", "smooth"]


@dataclass(frozen=True, eq=False)
class Smoothed:
    """``nav`` (K, 10) the smoothed nav per IMU sample; per propagation epoch j:
    ``dx`` (J, n) the smoothed error of the filtered nav, ``p_diag`` (J, n) the
    diagonal of the smoothed covariance."""

    nav: FloatArray
    dx: FloatArray
    p_diag: FloatArray


@numba.njit(cache=True)
def _backward(
    epoch_in: FloatArray, p_filt: FloatArray, x_filt: FloatArray, qc: FloatArray, tau: float
) -> tuple[FloatArray, FloatArray]:
    n_ep, n = x_filt.shape
    dx = np.zeros((n_ep, n))
    p_diag = np.zeros((n_ep, n))
    ps = p_filt[n_ep - 1].copy()
    for i in range(n):
        p_diag[n_ep - 1, i] = ps[i, i]
    a = np.zeros((n, n))
    gc = np.zeros((n, n))
    for j in range(n_ep - 2, -1, -1):
        pf = p_filt[j]
        phi, q = phi_q(epoch_in[j + 1], qc, tau, n)
        pp = propagate_cov(pf, phi, q)
        # C^T = (P^-)^-1 Phi P_j (P^- symmetric)
        a[:, :] = 0.0
        for r in range(n):
            for k in range(n):
                f = phi[r, k]
                if f != 0.0:
                    for c in range(n):
                        a[r, c] += f * pf[k, c]
        ct = cholesky_solve_nb(pp, a)
        nxt = dx[j + 1] + x_filt[j + 1]
        for r in range(n):
            acc = 0.0
            for k in range(n):
                acc += ct[k, r] * nxt[k]
            dx[j, r] = acc
        # P^s_j = P_j + C (P^s - P^-) C^T
        d = ps - pp
        gc[:, :] = 0.0
        for r in range(n):
            for k in range(n):
                f = ct[k, r]
                for c in range(n):
                    gc[r, c] += f * d[k, c]
        for r in range(n):
            for c in range(r, n):
                acc = 0.0
                for k in range(n):
                    acc += gc[r, k] * ct[k, c]
                v = pf[r, c] + acc
                ps[r, c] = v
                ps[c, r] = v
            p_diag[j, r] = ps[r, r]
    return dx, p_diag


@numba.njit(cache=True)
def _apply(
    t: FloatArray, nav: FloatArray, epoch_k: np.ndarray, dx: FloatArray, x_filt: FloatArray
) -> FloatArray:
    out = np.empty_like(nav)
    n_ep, n = dx.shape
    corr = np.empty(n)
    for j in range(n_ep - 1):
        k0, k1 = epoch_k[j], epoch_k[j + 1]
        span = t[k1] - t[k0]
        for k in range(k0, k1):
            a = (t[k] - t[k0]) / span
            for i in range(n):
                corr[i] = (1.0 - a) * dx[j, i] + a * (dx[j + 1, i] + x_filt[j + 1, i])
            out[k] = apply_correction_nb(nav[k], corr)
    k_last = epoch_k[n_ep - 1]
    out[k_last] = apply_correction_nb(nav[k_last], dx[n_ep - 1])
    return out


def smooth(time_s: FloatArray, run: ForwardRun, figures: ImuFigures) -> Smoothed:
    """The RTS-smoothed solution of a forward run (``figures`` those of the run)."""
    n = run.x_filt.shape[1]
    qc = continuous_noise(figures, n)
    dx, p_diag = _backward(run.epoch_in, run.p_filt, run.x_filt, qc, figures.correlation_time)
    t = np.ascontiguousarray(time_s, dtype=np.float64)
    return Smoothed(_apply(t, run.nav, run.epoch_k, dx, run.x_filt), dx, p_diag)
