"""A plain driver of the INS filter: mechanize every IMU sample, propagate the error state
every ``cov_every`` samples, apply the measurements an ``aiding`` callback returns, feed
back (closed loop). The reference loop for tests and for the compiled pipeline version
that issue 12 item 4 wires into ``coopproc run``.

:func:`run_events` is the same loop over an :class:`EventPlan` (the aiding as arrays, as
:mod:`coopproc.ins.engine` prepares it): the plain reference of the compiled
:func:`coopproc.ins.kernels.forward`, storing what the RTS smoother needs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from coopproc.estimation.robust import GAMMA_REJECT, igg3_scalar
from coopproc.ins.errorstate import ErrorStateEkf, Measurement
from coopproc.ins.mechanize import NavSolution, ins_step
from coopproc.ins.updates import (
    nhc_update,
    odometer_update,
    position_update,
    range_update,
    zero_velocity_update,
)
from coopproc.model import FloatArray

__all__ = [
    "EPOCH_IN",
    "KIND_NAMES",
    "N_STAT",
    "Aiding",
    "EventPlan",
    "ForwardRun",
    "run_events",
    "run_filter",
]

#: aiding(k, nav, w_b) -> measurements at sample k (nav after the step; w_b compensated rate)
Aiding = Callable[[int, FloatArray, FloatArray], list[Measurement]]


def run_filter(
    time_s: FloatArray,
    dtheta: FloatArray,
    dvel: FloatArray,
    nav0: FloatArray,
    ekf: ErrorStateEkf,
    aiding: Aiding | None = None,
    cov_every: int = 10,
    robust: tuple[float, float] | None = None,
) -> NavSolution:
    """Closed-loop INS/EKF over all samples; ``ekf`` holds the final state afterwards.

    The covariance is propagated over blocks of ``cov_every`` samples with the block's
    summed increments (F evaluated once per block), and before every aided sample.
    """
    t = np.asarray(time_s, dtype=np.float64)
    out = np.empty((t.shape[0], nav0.shape[0]))
    nav = np.array(nav0, dtype=np.float64)
    out[0] = nav
    dth_prev, dv_prev = ekf.compensate(dtheta[0], dvel[0], t[1] - t[0])
    acc_th, acc_v, acc_dt = np.zeros(3), np.zeros(3), 0.0
    for k in range(1, t.shape[0]):
        dt = t[k] - t[k - 1]
        dth, dv = ekf.compensate(dtheta[k], dvel[k], dt)
        nav_before = nav.copy()
        ins_step(nav, dth_prev, dv_prev, dth, dv, dt)
        acc_th += dth
        acc_v += dv
        acc_dt += dt
        meas = aiding(k, nav, dth / dt) if aiding is not None else []
        if meas or k % cov_every == 0 or k == t.shape[0] - 1:
            ekf.propagate(nav_before, acc_th, acc_v, acc_dt)
            acc_th, acc_v, acc_dt = np.zeros(3), np.zeros(3), 0.0
        for m in meas:
            ekf.update(m, robust)
        if meas:
            nav = ekf.feedback(nav)
        out[k] = nav
        dth_prev, dv_prev = dth, dv
    return NavSolution(time_s=t, nav=out)


#: Aiding kinds of an :class:`EventPlan` (rows of the innovation statistics too).
RANGE, POSITION, SPEED, NHC, ZUPT = 0, 1, 2, 3, 4
KIND_NAMES = ("range", "position", "speed", "nhc", "zupt")
#: Columns of the statistics: scalar innovations, accepted, down-weighted, rejected,
#: sum of squared normalized innovations.
N_STAT = 5
#: Values per propagation epoch that let the smoother rebuild Phi and Q: the nav the
#: block's F is evaluated at (10), the block's compensated increments (3 + 3) and length.
EPOCH_IN = 17


class EventPlan(NamedTuple):
    """The aiding of one run as arrays, each measurement tied to an IMU sample.

    ``kind``/``k``/``dt``/``data``: one row per measurement event, sorted by ``k`` (then
    kind, time): ``dt`` = t_meas - t_k (the innovation is taken at t_meas with the INS
    velocity); ``data`` range: (lat, lon, h of the point, range, sigma); position:
    (lat, lon, h, sigma E, N, U); speed: (speed, sigma). ``lever`` (3, 3): the lever
    arm (body, m) of range, position and speed. ``nhc_every``/``zupt_every``: NHC and
    zero-velocity updates at samples k with k % every == 0 (0: off), zero velocity only
    where ``static[k]``. ``is_epoch[k]``: the covariance is propagated at sample k (every
    ``cov_every`` samples, every aided sample and the last). ``robust`` (k0, k1) or
    k0 <= 0 for none (IGG-III on range, position and speed). A ``NamedTuple``: the
    compiled loop (:mod:`coopproc.ins.kernels`) takes it whole.
    """

    kind: npt.NDArray[np.int64]
    k: npt.NDArray[np.int64]
    dt: FloatArray
    data: FloatArray
    lever: FloatArray
    nhc_every: int
    nhc_sigma: FloatArray
    nhc_lever: FloatArray
    zupt_every: int
    zupt_sigma: float
    static: npt.NDArray[np.bool_]
    is_epoch: npt.NDArray[np.bool_]
    robust: FloatArray


@dataclass(frozen=True, eq=False)
class ForwardRun:
    """What the forward filter leaves: the closed-loop nav per IMU sample and, per
    propagation epoch j (at sample ``epoch_k[j]``), what the smoother needs: ``epoch_in``
    (J, EPOCH_IN), the filtered covariance ``p_filt`` (J, n, n) and the error state
    ``x_filt`` (J, n) the updates estimated (fed back, then reset to 0). ``stats``
    (5, N_STAT) per kind; ``sensor`` (12): the final gyro/accel bias, scale estimates."""

    nav: FloatArray
    epoch_k: npt.NDArray[np.int64]
    epoch_in: FloatArray
    p_filt: FloatArray
    x_filt: FloatArray
    stats: FloatArray
    sensor: FloatArray


def _scalar_updates(
    ekf: ErrorStateEkf, meas: Measurement, robust: FloatArray, row: FloatArray
) -> None:
    """ErrorStateEkf.update with the statistics of each scalar innovation in ``row``."""
    for i in range(meas.v.shape[0]):
        h = np.zeros(ekf.n)
        h[: meas.h.shape[1]] = meas.h[i]
        innov = meas.v[i] - h @ ekf.x
        ph = ekf.p @ h
        s = h @ ph + meas.r[i]
        z = innov / np.sqrt(s)
        gamma = 1.0
        if robust[0] > 0.0:
            gamma = igg3_scalar(z, robust[0], robust[1])
            s = h @ ph + meas.r[i] / gamma
        row[0] += 1.0
        row[1 if gamma == 1.0 else (3 if gamma <= GAMMA_REJECT else 2)] += 1.0
        row[4] += z * z
        g = ph / s
        ekf.x = ekf.x + g * innov
        p = ekf.p - np.outer(g, ph)
        ekf.p = 0.5 * (p + p.T)


def _event_measurement(plan: EventPlan, e: int, nav: FloatArray, w_b: FloatArray) -> Measurement:
    d, kind = plan.data[e], int(plan.kind[e])
    if kind == RANGE:
        m = range_update(nav, d[0:3], plan.lever[RANGE], float(d[3]), float(d[4]))
        v = m.v + (m.h[0, 0:3] @ nav[3:6]) * plan.dt[e]
        return Measurement(v, m.h, m.r)
    if kind == POSITION:
        m = position_update(nav, d[0:3], plan.lever[POSITION], d[3:6])
        return Measurement(m.v + nav[3:6] * plan.dt[e], m.h, m.r)
    return odometer_update(nav, w_b, float(d[0]), float(d[1]), plan.lever[SPEED])


def run_events(
    time_s: FloatArray,
    dtheta: FloatArray,
    dvel: FloatArray,
    nav0: FloatArray,
    ekf: ErrorStateEkf,
    plan: EventPlan,
    progress: Callable[[float], None] | None = None,
) -> ForwardRun:
    """The forward closed-loop filter over an :class:`EventPlan`, plainly in numpy/Python:
    the reference of the compiled :func:`coopproc.ins.kernels.forward` (same order of
    operations) and the benchmark's baseline."""
    t = np.asarray(time_s, dtype=np.float64)
    k_n, n = t.shape[0], ekf.n
    n_ep = int(np.count_nonzero(plan.is_epoch))
    out = np.empty((k_n, nav0.shape[0]))
    epoch_k = np.zeros(n_ep, dtype=np.int64)
    epoch_in = np.zeros((n_ep, EPOCH_IN))
    p_filt = np.zeros((n_ep, n, n))
    x_filt = np.zeros((n_ep, n))
    stats = np.zeros((5, N_STAT))
    nav = np.array(nav0, dtype=np.float64)
    out[0] = nav
    p_filt[0] = ekf.p
    j, e = 1, 0
    dth_prev, dv_prev = ekf.compensate(dtheta[0], dvel[0], t[1] - t[0])
    acc_th, acc_v, acc_dt = np.zeros(3), np.zeros(3), 0.0
    for k in range(1, k_n):
        dt = t[k] - t[k - 1]
        dth, dv = ekf.compensate(dtheta[k], dvel[k], dt)
        nav_before = nav.copy()
        ins_step(nav, dth_prev, dv_prev, dth, dv, dt)
        acc_th += dth
        acc_v += dv
        acc_dt += dt
        if plan.is_epoch[k]:
            ekf.propagate(nav_before, acc_th, acc_v, acc_dt)
            epoch_k[j] = k
            epoch_in[j] = np.concatenate([nav_before, acc_th, acc_v, [acc_dt]])
            acc_th, acc_v, acc_dt = np.zeros(3), np.zeros(3), 0.0
            w_b = dth / dt
            while e < plan.k.shape[0] and plan.k[e] == k:
                meas = _event_measurement(plan, e, nav, w_b)
                _scalar_updates(ekf, meas, plan.robust, stats[plan.kind[e]])
                e += 1
            if plan.nhc_every > 0 and k % plan.nhc_every == 0:
                meas = nhc_update(nav, w_b, 1.0, plan.nhc_lever)
                meas = Measurement(meas.v, meas.h, plan.nhc_sigma**2)
                _scalar_updates(ekf, meas, _NO_ROBUST, stats[NHC])
            if plan.zupt_every > 0 and k % plan.zupt_every == 0 and plan.static[k]:
                meas = zero_velocity_update(nav, plan.zupt_sigma)
                _scalar_updates(ekf, meas, _NO_ROBUST, stats[ZUPT])
            p_filt[j] = ekf.p
            x_filt[j] = ekf.x
            nav = ekf.feedback(nav)
            j += 1
            if progress is not None and j % 2000 == 0:
                progress(k / (k_n - 1))
        out[k] = nav
        dth_prev, dv_prev = dth, dv
    sensor = np.concatenate([ekf.bias_g, ekf.bias_a, ekf.scale_g, ekf.scale_a])
    return ForwardRun(out, epoch_k, epoch_in, p_filt, x_filt, stats, sensor)


_NO_ROBUST = np.zeros(2)
