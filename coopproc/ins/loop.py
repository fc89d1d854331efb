"""A plain driver of the INS filter: mechanize every IMU sample, propagate the error state
every ``cov_every`` samples, apply the measurements an ``aiding`` callback returns, feed
back (closed loop). The reference loop for tests and for the compiled pipeline version
that issue 12 item 4 wires into ``coopproc run``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from coopproc.ins.errorstate import ErrorStateEkf, Measurement
from coopproc.ins.mechanize import NavSolution, ins_step
from coopproc.model import FloatArray

__all__ = ["Aiding", "run_filter"]

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
