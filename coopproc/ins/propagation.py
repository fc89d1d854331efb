"""Compiled pieces of the error-state filter shared by the forward loop
(:mod:`coopproc.ins.kernels`) and the RTS smoother (:mod:`coopproc.ins.smoother`): the
block's Phi and Q (:func:`coopproc.ins.errorstate.f_matrix`, ``discretize`` and
``process_noise`` written element-wise), the covariance propagation and the feedback
(docs/methods-ins.md, "Compiled loop")."""

from __future__ import annotations

import numba
import numpy as np

from coopproc.ins.earth import earth_rate_enu, normal_gravity, radii, transport_rate_enu
from coopproc.ins.errorstate import N_BASE
from coopproc.ins.models import ImuFigures
from coopproc.ins.quat import qmul, quat_to_dcm, rotvec_to_quat
from coopproc.model import FloatArray

__all__ = ["apply_correction_nb", "continuous_noise", "phi_q", "propagate_cov"]


def continuous_noise(fig: ImuFigures, n: int) -> FloatArray:
    """Q_c's diagonal as :func:`coopproc.ins.errorstate.process_noise` builds it."""
    q_bg, q_ba = fig.bias_psd()
    qc = np.zeros(n)
    qc[3:6] = fig.vrw_mps_rts**2
    qc[6:9] = fig.arw_rad_rts**2
    qc[9:12] = q_bg
    qc[12:15] = q_ba
    if n > N_BASE:
        qc[15:18] = 2.0 * (fig.gyro_scale * 1e-6) ** 2 / fig.correlation_time
        qc[18:21] = 2.0 * (fig.accel_scale * 1e-6) ** 2 / fig.correlation_time
    return qc


@numba.njit(cache=True)
def _dcm_rates(nav: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(C_b^n, omega_ie^n, omega_en^n) at ``nav``."""
    return (
        quat_to_dcm(nav[6:10]),
        earth_rate_enu(nav[0]),
        transport_rate_enu(nav[0], nav[2], nav[3:6]),
    )


@numba.njit(cache=True)
def _put_skew(f: FloatArray, r: int, c: int, v: FloatArray, sign: float) -> None:
    """f[r:r+3, c:c+3] = sign [v x]."""
    f[r, c + 1] = -sign * v[2]
    f[r, c + 2] = sign * v[1]
    f[r + 1, c] = sign * v[2]
    f[r + 1, c + 2] = -sign * v[0]
    f[r + 2, c] = -sign * v[1]
    f[r + 2, c + 1] = sign * v[0]


@numba.njit(cache=True)
def phi_q(ein: FloatArray, qc: FloatArray, tau: float, n: int) -> tuple[FloatArray, FloatArray]:
    """(Phi, Q) of one propagation block from its ``epoch_in`` row (nav the F is taken
    at, summed compensated increments, length): f_matrix, discretize, process_noise
    written in loops (small matrices; quick to compile)."""
    nav = ein[0:10]
    dt = ein[16]
    lat, h = nav[0], nav[2]
    c, w_ie, w_en = _dcm_rates(nav)
    m, nn = radii(lat)
    f_n = np.zeros(3)
    for i in range(3):
        for j in range(3):
            f_n[i] += c[i, j] * ein[13 + j] / dt
    f = np.zeros((n, n))
    _put_skew(f, 0, 0, w_en, -1.0)
    _put_skew(f, 3, 6, f_n, 1.0)
    _put_skew(f, 3, 3, 2.0 * w_ie + w_en, -1.0)
    _put_skew(f, 6, 6, w_ie + w_en, -1.0)
    for i in range(3):
        f[i, 3 + i] = 1.0
        for j in range(3):
            f[3 + i, 12 + j] = c[i, j]
            f[6 + i, 9 + j] = -c[i, j]
            if n > N_BASE:
                f[6 + i, 15 + j] = -c[i, j] * ein[10 + j] / dt
                f[3 + i, 18 + j] = c[i, j] * ein[13 + j] / dt
    f[5, 2] = 2.0 * normal_gravity(lat, h) / (np.sqrt(m * nn) + h)
    for i in range(9, n):
        f[i, i] = -1.0 / tau
    phi = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            a = f[i, k] * dt
            if a != 0.0:
                for j in range(n):
                    phi[i, j] += 0.5 * a * f[k, j] * dt
        for j in range(n):
            phi[i, j] += f[i, j] * dt
        phi[i, i] += 1.0
    q = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += phi[i, k] * qc[k] * phi[j, k]
            q[i, j] = 0.5 * acc * dt
            q[j, i] = q[i, j]
        q[i, i] += 0.5 * qc[i] * dt
    return phi, q


@numba.njit(cache=True)
def propagate_cov(p: FloatArray, phi: FloatArray, q: FloatArray) -> FloatArray:
    """Phi P Phi^T + Q, symmetric (a new array)."""
    n = p.shape[0]
    tmp = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            a = phi[i, k]
            if a != 0.0:
                for j in range(n):
                    tmp[i, j] += a * p[k, j]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += tmp[i, k] * phi[j, k]
            out[i, j] = acc + 0.5 * (q[i, j] + q[j, i])
            out[j, i] = out[i, j]
    return out


@numba.njit(cache=True)
def apply_correction_nb(nav: FloatArray, dx: FloatArray) -> FloatArray:
    """:func:`coopproc.ins.errorstate.apply_correction`, compiled."""
    out = nav.copy()
    m, n = radii(nav[0])
    h = nav[2]
    out[0] = nav[0] - dx[1] / (m + h)
    out[1] = nav[1] - dx[0] / ((n + h) * np.cos(nav[0]))
    out[2] = h - dx[2]
    for i in range(3):
        out[3 + i] = nav[3 + i] - dx[3 + i]
    phi = np.empty(3)
    phi[0] = dx[6] - dx[1] / (m + h)
    phi[1] = dx[7] + dx[0] / (n + h)
    phi[2] = dx[8] + dx[0] * np.tan(nav[0]) / (n + h)
    q = qmul(rotvec_to_quat(phi), nav[6:10])
    out[6:10] = q / np.sqrt(np.sum(q * q))
    return out
