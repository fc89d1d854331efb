"""The INS filter as one compiled loop (issue 12 item 7): mechanization, covariance
propagation, the measurement updates of an :class:`~coopproc.ins.loop.EventPlan` and the
closed-loop feedback, numba-compiled over arrays (docs/methods-ins.md, "Compiled loop").

The same operations in the same order as the plain :func:`coopproc.ins.loop.run_events`
(which uses :mod:`coopproc.ins.errorstate` and :mod:`coopproc.ins.updates`), so the two
agree to rounding; F, Phi, Q and the feedback are in :mod:`coopproc.ins.propagation`.
One compiled signature: float64 arrays, 15 or 21 states chosen by the covariance shape.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numba
import numpy as np
import numpy.typing as npt

from coopproc.estimation.range_model import lever_arm_row, range_unit
from coopproc.estimation.robust import GAMMA_REJECT, igg3_scalar
from coopproc.ins.earth import ecef_to_enu_matrix, llh_to_ecef
from coopproc.ins.errorstate import N_BASE, ErrorStateEkf
from coopproc.ins.loop import EPOCH_IN, N_STAT, EventPlan, ForwardRun
from coopproc.ins.mechanize import ins_step
from coopproc.ins.propagation import (
    apply_correction_nb,
    continuous_noise,
    phi_q,
    propagate_cov,
)
from coopproc.ins.quat import quat_to_dcm
from coopproc.ins.rows import body_velocity_row, position_row
from coopproc.model import FloatArray

__all__ = ["CHUNK", "forward"]

#: Samples per call of the compiled loop between two progress reports.
CHUNK = 200_000


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
        vb = body_velocity_row(c, nav[3:6], w_b, lever, 0, h)  # the forward speed
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
        u = np.zeros(3)
        rho = range_unit(dd, 0.0, u)
        h[0], h[1], h[2] = u[0], u[1], u[2]
        lever_arm_row(u, cl, h[6:9])  # u^T [cl x] = (u x cl)^T
        vu = u[0] * nav[3] + u[1] * nav[4] + u[2] * nav[5]
        _update(p, x, h, rho - d[3] + vu * dte, d[4] * d[4], robust, stats, 0)
        h[:] = 0.0
        return
    for i in range(3):
        position_row(cl, i, h)
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
        for r in range(1, 3):  # the lateral and vertical body velocity
            vb = body_velocity_row(c, nav[3:6], w_b, nhc_lever, r, h)
            _update(p, x, h, vb, nhc_sigma[r - 1] ** 2, none, stats, 3)
            h[:] = 0.0
    if zupt:
        for i in range(3):
            h[3 + i] = 1.0
            _update(p, x, h, nav[3 + i], zupt_sigma * zupt_sigma, none, stats, 4)
            h[:] = 0.0


class ImuSamples(NamedTuple):
    """The IMU samples: times (K,), angle and velocity increments (K, 3)."""

    t: FloatArray
    dth: FloatArray
    dv: FloatArray


class LoopState(NamedTuple):
    """The loop's state between chunks: nav (10), the previous compensated increments,
    the covariance epoch's accumulated increments and length (7), the sensor errors
    (12), P, the error state, and [next event, next propagation epoch]."""

    nav: FloatArray
    dth_prev: FloatArray
    dv_prev: FloatArray
    acc: FloatArray
    sens: FloatArray
    p: FloatArray
    x: FloatArray
    ptr: npt.NDArray[np.int64]


class LoopRecord(NamedTuple):
    """What the loop writes: nav per sample, and per propagation epoch its sample, the
    smoother's inputs, the filtered P and error state; the innovation statistics."""

    out: FloatArray
    epoch_k: npt.NDArray[np.int64]
    epoch_in: FloatArray
    p_filt: FloatArray
    x_filt: FloatArray
    stats: FloatArray


@numba.njit(cache=True)
def _forward_chunk(
    imu: ImuSamples, k0: int, k1: int, st: LoopState, plan: EventPlan, qc: FloatArray,
    tau: float, rec: LoopRecord,
) -> None:  # fmt: skip
    """Samples k0..k1-1 of the loop of run_events; the state lives in ``st``'s arrays,
    what the smoother reads is written to ``rec``."""
    t, dth_raw, dv_raw = imu
    nav, dth_prev, dv_prev, acc, sens, p, x, ptr = st
    out, epoch_k, epoch_in, p_filt, x_filt, stats = rec
    ev_kind, ev_k, ev_dt, ev_data, lever = plan.kind, plan.k, plan.dt, plan.data, plan.lever
    nhc_every, nhc_sigma, nhc_lever = plan.nhc_every, plan.nhc_sigma, plan.nhc_lever
    zupt_every, zupt_sigma, static = plan.zupt_every, plan.zupt_sigma, plan.static
    is_epoch, robust = plan.is_epoch, plan.robust
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
    imu = ImuSamples(t, dth, dv)
    st = LoopState(nav, dth_prev, dv_prev, acc, sens, p, x, ptr)
    rec = LoopRecord(out, epoch_k, epoch_in, p_filt, x_filt, stats)
    for k0 in range(1, k_n, CHUNK):
        k1 = min(k0 + CHUNK, k_n)
        _forward_chunk(imu, k0, k1, st, plan, qc, tau, rec)
        if progress is not None:
            progress((k1 - 1) / (k_n - 1))
    return ForwardRun(out, epoch_k, epoch_in, p_filt, x_filt, stats, sens)
