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
from coopproc.ins.quat import qmul, quat_to_dcm, rotvec_to_quat, skew
from coopproc.model import FloatArray
from coopproc.stages.filters import GAMMA_REJECT, igg3_scalar

__all__ = ["apply_correction_nb", "continuous_noise", "forward", "phi_q"]

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
def phi_q(ein: FloatArray, qc: FloatArray, tau: float, n: int) -> tuple[FloatArray, FloatArray]:
    """(Phi, Q) of one propagation block from its ``epoch_in`` row (nav the F is taken
    at, summed compensated increments, length): f_matrix, discretize, process_noise."""
    nav = ein[0:10]
    dt = ein[16]
    f_b = ein[13:16] / dt
    w_b = ein[10:13] / dt
    lat, h = nav[0], nav[2]
    c = quat_to_dcm(nav[6:10])
    w_ie = earth_rate_enu(lat)
    w_en = transport_rate_enu(lat, h, nav[3:6])
    m, nn = radii(lat)
    f = np.zeros((n, n))
    f[0:3, 0:3] = -skew(w_en)
    for i in range(3):
        f[i, 3 + i] = 1.0
    f[3:6, 6:9] = skew(c @ f_b)
    f[3:6, 3:6] = -skew(2.0 * w_ie + w_en)
    f[5, 2] = 2.0 * normal_gravity(lat, h) / (np.sqrt(m * nn) + h)
    f[3:6, 12:15] = c
    f[6:9, 6:9] = -skew(w_ie + w_en)
    f[6:9, 9:12] = -c
    for i in range(9, n):
        f[i, i] = -1.0 / tau
    if n > N_BASE:
        for i in range(3):
            for j in range(3):
                f[6 + i, 15 + j] = -c[i, j] * w_b[j]
                f[3 + i, 18 + j] = c[i, j] * f_b[j]
    fdt = f * dt
    phi = np.eye(n) + fdt + 0.5 * (fdt @ fdt)
    q = 0.5 * ((phi * qc.reshape(1, n)) @ phi.T)
    for i in range(n):
        q[i, i] += 0.5 * qc[i]
    return phi, q * dt


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
    ph = p @ h
    innov = v - h @ x
    hph = h @ ph
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
        x[i] += ph[i] / s * innov
    for i in range(n):
        gi = ph[i] / s
        for j in range(n):
            p[i, j] -= gi * ph[j]
    for i in range(n):
        for j in range(i + 1, n):
            a = 0.5 * (p[i, j] + p[j, i])
            p[i, j] = a
            p[j, i] = a


@numba.njit(cache=True)
def _antenna(nav: FloatArray, lever: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    c_en = ecef_to_enu_matrix(nav[0], nav[1])
    cl = quat_to_dcm(nav[6:10]) @ lever
    return llh_to_ecef(nav[0], nav[1], nav[2]) + c_en.T @ cl, c_en, cl


@numba.njit(cache=True)
def _event(
    nav: FloatArray, w_b: FloatArray, kind: int, dte: float, d: FloatArray, lever: FloatArray,
    p: FloatArray, x: FloatArray, robust: FloatArray, stats: FloatArray,
) -> None:  # fmt: skip
    """Range (0), position (1) or odometer speed (2) update, as coopproc.ins.updates."""
    n = x.shape[0]
    h = np.zeros(n)
    if kind == 2:
        c = quat_to_dcm(nav[6:10])
        vb = c.T @ nav[3:6] + np.cross(w_b, lever)
        h[3:6] = c.T[0]
        h[6:9] = (-c.T @ skew(nav[3:6]))[0]
        h[9:12] = -skew(lever)[0]
        _update(p, x, h, vb[0] - d[0], d[1] * d[1], robust, stats, 2)
        return
    ant, c_en, cl = _antenna(nav, lever)
    dd = c_en @ (ant - llh_to_ecef(d[0], d[1], d[2]))
    if kind == 0:
        rho = np.sqrt(np.sum(dd * dd))
        u = dd / max(rho, 1e-9)
        h[0:3] = u
        h[6:9] = u @ skew(cl)
        _update(p, x, h, rho - d[3] + (u @ nav[3:6]) * dte, d[4] * d[4], robust, stats, 0)
        return
    sk = skew(cl)
    for i in range(3):
        h[:] = 0.0
        h[i] = 1.0
        h[6:9] = sk[i]
        _update(p, x, h, dd[i] + nav[3 + i] * dte, d[3 + i] * d[3 + i], robust, stats, 1)


@numba.njit(cache=True)
def _pseudo(
    nav: FloatArray, w_b: FloatArray, nhc: bool, zupt: bool, nhc_sigma: FloatArray,
    nhc_lever: FloatArray, zupt_sigma: float, p: FloatArray, x: FloatArray, stats: FloatArray,
) -> None:  # fmt: skip
    """NHC (rows y, z of the body velocity) and zero velocity, never robust."""
    n = x.shape[0]
    h = np.zeros(n)
    none = np.zeros(2)
    if nhc:
        c = quat_to_dcm(nav[6:10])
        vb = c.T @ nav[3:6] + np.cross(w_b, nhc_lever)
        ha = -c.T @ skew(nav[3:6])
        sl = -skew(nhc_lever)
        for r in range(1, 3):
            h[:] = 0.0
            h[3:6] = c.T[r]
            h[6:9] = ha[r]
            h[9:12] = sl[r]
            _update(p, x, h, vb[r], nhc_sigma[r - 1] ** 2, none, stats, 3)
    if zupt:
        for i in range(3):
            h[:] = 0.0
            h[3 + i] = 1.0
            _update(p, x, h, nav[3 + i], zupt_sigma * zupt_sigma, none, stats, 4)


@numba.njit(cache=True)
def _forward_chunk(
    t: FloatArray, dth_raw: FloatArray, dv_raw: FloatArray, k0: int, k1: int,
    nav: FloatArray, prev: FloatArray, acc: FloatArray, sens: FloatArray, p: FloatArray,
    x: FloatArray, ptr: np.ndarray,
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
    for k in range(k0, k1):
        dt = t[k] - t[k - 1]
        for i in range(3):
            dth[i] = dth_raw[k, i] - sens[i] * dt
            dv[i] = dv_raw[k, i] - sens[3 + i] * dt
            if scaled:
                dth[i] /= 1.0 + sens[6 + i]
                dv[i] /= 1.0 + sens[9 + i]
        nav_before[:] = nav
        ins_step(nav, prev[0:3], prev[3:6], dth, dv, dt)
        acc[0:3] += dth
        acc[3:6] += dv
        acc[6] += dt
        if is_epoch[k]:
            j = ptr[1]
            ein = epoch_in[j]
            ein[0:10] = nav_before
            ein[10:16] = acc[0:6]
            ein[16] = acc[6]
            phi, q = phi_q(ein, qc, tau, n)
            x[:] = phi @ x
            pp = phi @ p @ phi.T + q
            p[:, :] = 0.5 * (pp + pp.T)
            epoch_k[j] = k
            acc[:] = 0.0
            w_b = dth / dt
            e = ptr[0]
            while e < n_ev and ev_k[e] == k:
                kd = ev_kind[e]
                _event(nav, w_b, kd, ev_dt[e], ev_data[e], lever[kd], p, x, robust, stats)
                e += 1
            ptr[0] = e
            nhc = nhc_every > 0 and k % nhc_every == 0
            zupt = zupt_every > 0 and k % zupt_every == 0 and static[k]
            if nhc or zupt:
                _pseudo(nav, w_b, nhc, zupt, nhc_sigma, nhc_lever, zupt_sigma, p, x, stats)
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
        prev[0:3] = dth
        prev[3:6] = dv


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
    prev = np.concatenate([th0, v0]).astype(np.float64)
    acc = np.zeros(7)
    ptr = np.array([0, 1], dtype=np.int64)
    qc = continuous_noise(ekf.noise, n)
    tau = float(ekf.noise.correlation_time)
    for k0 in range(1, k_n, CHUNK):
        k1 = min(k0 + CHUNK, k_n)
        _forward_chunk(
            t, dth, dv, k0, k1, nav, prev, acc, sens, p, x, ptr,
            plan.kind, plan.k, plan.dt, plan.data, plan.lever, plan.nhc_every,
            plan.nhc_sigma, plan.nhc_lever, plan.zupt_every, plan.zupt_sigma,
            plan.static, plan.is_epoch, plan.robust, qc, tau,
            out, epoch_k, epoch_in, p_filt, x_filt, stats,
        )  # fmt: skip
        if progress is not None:
            progress((k1 - 1) / (k_n - 1))
    return ForwardRun(out, epoch_k, epoch_in, p_filt, x_filt, stats, sens)
