"""The INS filter as one compiled loop (issue 12 item 7): mechanization, covariance
propagation, the measurement updates of an :class:`~coopproc.ins.loop.EventPlan` and the
closed-loop feedback, numba-compiled over arrays (docs/methods-ins.md, "Compiled loop").

The same operations in the same order as the plain :func:`coopproc.ins.loop.run_events`
(which uses :mod:`coopproc.ins.errorstate` and :mod:`coopproc.ins.updates`), so the two
agree to rounding; the helpers here (F, Phi, Q, feedback) also serve the smoother.
One compiled signature: float64 arrays, 15 or 21 states chosen by the covariance shape.
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np

from coopproc.ins.earth import (
    earth_rate_enu,
    ecef_to_enu_matrix,
    llh_to_ecef,
    normal_gravity,
    radii,
    transport_rate_enu,
)
from coopproc.ins.errorstate import N_BASE, ErrorStateEkf
from coopproc.ins.loop import EPOCH_IN, N_STAT, EventPlan, ForwardRun
from coopproc.ins.mechanize import ins_step
from coopproc.ins.models import ImuFigures
from coopproc.ins.quat import qmul, quat_to_dcm, rotvec_to_quat
from coopproc.model import FloatArray
from coopproc.stages.filters import GAMMA_REJECT, igg3_scalar

__all__ = ["apply_correction_nb", "continuous_noise", "forward", "phi_q", "propagate_cov"]

#: Samples per call of the compiled loop between two progress reports.
CHUNK = 200_000


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


@numba.njit(cache=True)
def _update(
    p: FloatArray,
    x: FloatArray,
    h: FloatArray,
    v: float,
    r: float,
    robust: FloatArray,
    stats: FloatArray,
    kind: int,
) -> None:
    """One scalar update (ErrorStateEkf.update with statistics), h of length n."""
    n = x.shape[0]
    ph = np.zeros(n)
    hx = 0.0
    for i in range(n):
        hx += h[i] * x[i]
        if h[i] != 0.0:
            for j in range(n):
                ph[j] += p[j, i] * h[i]
    innov = v - hx
    hph = 0.0
    for i in range(n):
        hph += h[i] * ph[i]
    s = hph + r
    z = innov / np.sqrt(s)
    gamma = 1.0
    if robust[0] > 0.0:
        gamma = igg3_scalar(z, robust[0], robust[1])
        s = hph + r / gamma
    stats[kind, 0] += 1.0
    if gamma == 1.0:
        stats[kind, 1] += 1.0
    elif gamma <= GAMMA_REJECT:
        stats[kind, 3] += 1.0
    else:
        stats[kind, 2] += 1.0
    stats[kind, 4] += z * z
    for i in range(n):
        gi = ph[i] / s
        x[i] += gi * innov
        for j in range(n):
            p[i, j] -= gi * ph[j]
    for i in range(n):
        for j in range(i + 1, n):
            a = 0.5 * (p[i, j] + p[j, i])
            p[i, j] = a
            p[j, i] = a


@numba.njit(cache=True)
def _event(
    nav: FloatArray, w_b: FloatArray, kind: int, dte: float, d: FloatArray, lever: FloatArray,
    p: FloatArray, x: FloatArray, robust: FloatArray, stats: FloatArray, h: FloatArray,
) -> None:  # fmt: skip
    """Range (0), position (1) or odometer speed (2) update, as coopproc.ins.updates;
    ``h`` a scratch row of n zeros (left zero)."""
    c = quat_to_dcm(nav[6:10])
    if kind == 2:
        # v^b_x = C[:, 0] . v^n + (w x l)_x; H: [0, C[:, 0], -(C^T [v x])_0, -[l x]_0]
        vb = w_b[1] * lever[2] - w_b[2] * lever[1]
        for i in range(3):
            vb += c[i, 0] * nav[3 + i]
            h[3 + i] = c[i, 0]
        v = nav[3:6]
        h[6] = -(c[1, 0] * v[2] - c[2, 0] * v[1])
        h[7] = -(c[2, 0] * v[0] - c[0, 0] * v[2])
        h[8] = -(c[0, 0] * v[1] - c[1, 0] * v[0])
        h[10], h[11] = lever[2], -lever[1]
        _update(p, x, h, vb - d[0], d[1] * d[1], robust, stats, 2)
        h[:] = 0.0
        return
    c_en = ecef_to_enu_matrix(nav[0], nav[1])
    r_ins = llh_to_ecef(nav[0], nav[1], nav[2])
    r_pt = llh_to_ecef(d[0], d[1], d[2])
    cl = np.zeros(3)
    dd = np.zeros(3)
    for i in range(3):
        for j in range(3):
            cl[i] += c[i, j] * lever[j]
    for i in range(3):
        dd[i] = cl[i]
        for j in range(3):
            dd[i] += c_en[i, j] * (r_ins[j] - r_pt[j])
    if kind == 0:
        rho = np.sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2])
        u = dd / max(rho, 1e-9)
        # u^T [cl x] = (u x cl)^T
        h[0], h[1], h[2] = u[0], u[1], u[2]
        h[6] = u[1] * cl[2] - u[2] * cl[1]
        h[7] = u[2] * cl[0] - u[0] * cl[2]
        h[8] = u[0] * cl[1] - u[1] * cl[0]
        vu = u[0] * nav[3] + u[1] * nav[4] + u[2] * nav[5]
        _update(p, x, h, rho - d[3] + vu * dte, d[4] * d[4], robust, stats, 0)
        h[:] = 0.0
        return
    for i in range(3):
        # row i of [I, 0, [cl x]]
        h[i] = 1.0
        h[6 + (i + 1) % 3] = -cl[(i + 2) % 3]
        h[6 + (i + 2) % 3] = cl[(i + 1) % 3]
        _update(p, x, h, dd[i] + nav[3 + i] * dte, d[3 + i] * d[3 + i], robust, stats, 1)
        h[:] = 0.0


@numba.njit(cache=True)
def _pseudo(
    nav: FloatArray, w_b: FloatArray, nhc: bool, zupt: bool, nhc_sigma: FloatArray,
    nhc_lever: FloatArray, zupt_sigma: float, p: FloatArray, x: FloatArray, stats: FloatArray,
    h: FloatArray,
) -> None:  # fmt: skip
    """NHC (rows y, z of the body velocity) and zero velocity, never robust."""
    none = np.zeros(2)
    if nhc:
        c = quat_to_dcm(nav[6:10])
        v = nav[3:6]
        lv = nhc_lever
        wl = np.array([w_b[1] * lv[2] - w_b[2] * lv[1], w_b[2] * lv[0] - w_b[0] * lv[2],
                       w_b[0] * lv[1] - w_b[1] * lv[0]])  # fmt: skip
        for r in range(1, 3):
            vb = wl[r]
            for i in range(3):
                vb += c[i, r] * v[i]
                h[3 + i] = c[i, r]
            h[6] = -(c[1, r] * v[2] - c[2, r] * v[1])
            h[7] = -(c[2, r] * v[0] - c[0, r] * v[2])
            h[8] = -(c[0, r] * v[1] - c[1, r] * v[0])
            # -[l x] row r
            h[9 + (r + 1) % 3] = lv[(r + 2) % 3]
            h[9 + (r + 2) % 3] = -lv[(r + 1) % 3]
            _update(p, x, h, vb, nhc_sigma[r - 1] ** 2, none, stats, 3)
            h[:] = 0.0
    if zupt:
        for i in range(3):
            h[3 + i] = 1.0
            _update(p, x, h, nav[3 + i], zupt_sigma * zupt_sigma, none, stats, 4)
            h[:] = 0.0


@numba.njit(cache=True)
def _forward_chunk(
    t: FloatArray, dth_raw: FloatArray, dv_raw: FloatArray, k0: int, k1: int,
    nav: FloatArray, dth_prev: FloatArray, dv_prev: FloatArray, acc: FloatArray,
    sens: FloatArray, p: FloatArray, x: FloatArray, ptr: np.ndarray,
    ev_kind: np.ndarray, ev_k: np.ndarray, ev_dt: FloatArray, ev_data: FloatArray,
    lever: FloatArray, nhc_every: int, nhc_sigma: FloatArray, nhc_lever: FloatArray,
    zupt_every: int, zupt_sigma: float, static: np.ndarray, is_epoch: np.ndarray,
    robust: FloatArray, qc: FloatArray, tau: float,
    out: FloatArray, epoch_k: np.ndarray, epoch_in: FloatArray, p_filt: FloatArray,
    x_filt: FloatArray, stats: FloatArray,
) -> None:  # fmt: skip
    """Samples k0..k1-1 of the loop of run_events; the state lives in the arrays."""
    n = x.shape[0]
    n_ev = ev_k.shape[0]
    scaled = n > N_BASE
    nav_before = np.empty(10)
    dth = np.empty(3)
    dv = np.empty(3)
    w_b = np.empty(3)
    h = np.zeros(n)
    for k in range(k0, k1):
        dt = t[k] - t[k - 1]
        for i in range(3):
            dth[i] = dth_raw[k, i] - sens[i] * dt
            dv[i] = dv_raw[k, i] - sens[3 + i] * dt
            if scaled:
                dth[i] /= 1.0 + sens[6 + i]
                dv[i] /= 1.0 + sens[9 + i]
        nav_before[:] = nav
        ins_step(nav, dth_prev, dv_prev, dth, dv, dt)
        for i in range(3):
            acc[i] += dth[i]
            acc[3 + i] += dv[i]
        acc[6] += dt
        if is_epoch[k]:
            j = ptr[1]
            ein = epoch_in[j]
            ein[0:10] = nav_before
            ein[10:16] = acc[0:6]
            ein[16] = acc[6]
            phi, q = phi_q(ein, qc, tau, n)
            # x is zero after every feedback, so Phi x = 0
            p[:, :] = propagate_cov(p, phi, q)
            epoch_k[j] = k
            acc[:] = 0.0
            for i in range(3):
                w_b[i] = dth[i] / dt
            e = ptr[0]
            while e < n_ev and ev_k[e] == k:
                kd = ev_kind[e]
                _event(nav, w_b, kd, ev_dt[e], ev_data[e], lever[kd], p, x, robust, stats, h)
                e += 1
            ptr[0] = e
            nhc = nhc_every > 0 and k % nhc_every == 0
            zupt = zupt_every > 0 and k % zupt_every == 0 and static[k]
            if nhc or zupt:
                _pseudo(nav, w_b, nhc, zupt, nhc_sigma, nhc_lever, zupt_sigma, p, x, stats, h)
            p_filt[j] = p
            x_filt[j] = x
            nav[:] = apply_correction_nb(nav, x)
            for i in range(6):
                sens[i] += x[9 + i]
            if scaled:
                for i in range(6):
                    sens[6 + i] += x[15 + i]
            x[:] = 0.0
            ptr[1] = j + 1
        out[k] = nav
        dth_prev[:] = dth
        dv_prev[:] = dv


def forward(
    time_s: FloatArray,
    dtheta: FloatArray,
    dvel: FloatArray,
    nav0: FloatArray,
    ekf: ErrorStateEkf,
    plan: EventPlan,
    progress: Callable[[float], None] | None = None,
) -> ForwardRun:
    """:func:`coopproc.ins.loop.run_events` compiled: same arguments, same result to
    rounding. ``ekf`` gives P0, the figures and the state count (its state is not
    advanced). Runs in chunks of :data:`CHUNK` samples, ``progress`` between them."""
    t = np.ascontiguousarray(time_s, dtype=np.float64)
    dth = np.ascontiguousarray(dtheta, dtype=np.float64)
    dv = np.ascontiguousarray(dvel, dtype=np.float64)
    k_n, n = t.shape[0], ekf.n
    n_ep = int(np.count_nonzero(plan.is_epoch))
    out = np.empty((k_n, 10))
    epoch_k = np.zeros(n_ep, dtype=np.int64)
    epoch_in = np.zeros((n_ep, EPOCH_IN))
    p_filt = np.zeros((n_ep, n, n))
    x_filt = np.zeros((n_ep, n))
    stats = np.zeros((5, N_STAT))
    nav = np.array(nav0, dtype=np.float64)
    out[0] = nav
    p = np.array(ekf.p, dtype=np.float64)
    p_filt[0] = p
    x = np.zeros(n)
    sens = np.zeros(12)
    sens[0:3], sens[3:6], sens[6:9], sens[9:12] = ekf.bias_g, ekf.bias_a, ekf.scale_g, ekf.scale_a
    dt0 = t[1] - t[0]
    th0, v0 = ekf.compensate(dth[0], dv[0], dt0)
    dth_prev = np.array(th0, dtype=np.float64)
    dv_prev = np.array(v0, dtype=np.float64)
    acc = np.zeros(7)
    ptr = np.array([0, 1], dtype=np.int64)
    qc = continuous_noise(ekf.noise, n)
    tau = float(ekf.noise.correlation_time)
    for k0 in range(1, k_n, CHUNK):
        k1 = min(k0 + CHUNK, k_n)
        _forward_chunk(
            t, dth, dv, k0, k1, nav, dth_prev, dv_prev, acc, sens, p, x, ptr,
            plan.kind, plan.k, plan.dt, plan.data, plan.lever, plan.nhc_every,
            plan.nhc_sigma, plan.nhc_lever, plan.zupt_every, plan.zupt_sigma,
            plan.static, plan.is_epoch, plan.robust, qc, tau,
            out, epoch_k, epoch_in, p_filt, x_filt, stats,
        )  # fmt: skip
        if progress is not None:
            progress((k1 - 1) / (k_n - 1))
    return ForwardRun(out, epoch_k, epoch_in, p_filt, x_filt, stats, sens)
