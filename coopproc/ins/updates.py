"""Measurement models of the INS error-state EKF: innovation, design matrix and variance
of each aiding source (docs/methods-ins.md, "Updates").

Each function returns a :class:`~coopproc.ins.errorstate.Measurement` with innovation
v = h(INS) - z and H such that v = H dx + noise for the error state of
:mod:`coopproc.ins.errorstate` (INS minus true). Positions and ranges are formed in ECEF
(exact at any distance); their innovations and Jacobians are expressed in the ENU frame
at the INS position. Lever arms ``lever_b`` are body-frame vectors (m) from the IMU to
the antenna (or the odometer/constraint point).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.range_model import lever_arm_row, range_unit
from coopproc.ins.earth import ecef_to_enu_matrix, llh_to_ecef
from coopproc.ins.errorstate import ATT, N_BASE, POS, VEL, Measurement
from coopproc.ins.quat import quat_to_dcm
from coopproc.ins.rows import body_velocity_row, position_row
from coopproc.model import FloatArray

__all__ = [
    "antenna_ecef",
    "body_velocity_rows",
    "nhc_update",
    "odometer_update",
    "position_update",
    "range_update",
    "zero_velocity_update",
]


def antenna_ecef(nav: FloatArray, lever_b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(antenna ECEF, C_e^n at the INS position, C_b^n l) of the INS with lever arm l."""
    c_en = ecef_to_enu_matrix(nav[0], nav[1])
    cl = quat_to_dcm(nav[6:10]) @ np.asarray(lever_b, dtype=np.float64)
    return llh_to_ecef(nav[0], nav[1], nav[2]) + c_en.T @ cl, c_en, cl


def position_update(
    nav: FloatArray, meas_llh: FloatArray, lever_b: FloatArray, sigma_enu: FloatArray
) -> Measurement:
    """Loosely coupled position (paper 003 eq. (28)-(32), GNSS or UWB least squares):
    z the antenna at ``meas_llh`` (rad, rad, m); v = C_e^n (r_ant^e - z^e) (ENU, m);
    H = [I, 0, [(C_b^n l) x], 0, 0] (lever arm, eq. (29))."""
    ant, c_en, cl = antenna_ecef(nav, lever_b)
    v = c_en @ (ant - llh_to_ecef(meas_llh[0], meas_llh[1], meas_llh[2]))
    h = np.zeros((3, N_BASE))
    for i in range(3):
        position_row(cl, i, h[i])  # [I, 0, [cl x]]
    r = np.broadcast_to(np.asarray(sigma_enu, dtype=np.float64), 3) ** 2
    return Measurement(v, h, r.copy())


def range_update(
    nav: FloatArray, anchor_llh: FloatArray, lever_b: FloatArray, range_m: float, sigma_m: float
) -> Measurement:
    """Tightly coupled range from the UWB antenna to a known point (paper 002 eq. (9)-(10)):
    v = |r_ant - a| - range; H = u^T [I, 0, [(C_b^n l) x], 0, 0], u the ENU unit vector
    from the anchor to the antenna."""
    ant, c_en, cl = antenna_ecef(nav, lever_b)
    d = c_en @ (ant - llh_to_ecef(anchor_llh[0], anchor_llh[1], anchor_llh[2]))
    u = np.zeros(3)
    rho = float(range_unit(d, 0.0, u))
    h = np.zeros((1, N_BASE))
    h[0, POS] = u
    lever_arm_row(u, cl, h[0, ATT])  # u^T [cl x]
    return Measurement(np.array([rho - range_m]), h, np.array([sigma_m**2]))


def body_velocity_rows(
    nav: FloatArray, w_b: FloatArray, lever_b: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(v^b of the point at ``lever_b``, H (3, 15)): v^b = (C_b^n)^T v^n + w^b x l;
    H = [0, C^T, -C^T [v^n x], -[l x], 0] (paper 003 eq. (24)-(27) for l = 0; the gyro-bias
    column is the lever-arm term's). ``w_b``: the compensated body rate (rad/s)."""
    c = quat_to_dcm(nav[6:10])
    lever = np.asarray(lever_b, dtype=np.float64)
    w = np.asarray(w_b, dtype=np.float64)
    v = np.ascontiguousarray(nav[3:6], dtype=np.float64)
    h = np.zeros((3, N_BASE))
    v_b = np.array([body_velocity_row(c, v, w, lever, r, h[r]) for r in range(3)])
    return v_b, h


def nhc_update(
    nav: FloatArray,
    w_b: FloatArray,
    sigma_mps: float,
    lever_b: FloatArray | None = None,
) -> Measurement:
    """Non-holonomic constraints (paper 003 eq. (23)-(27)): the lateral and vertical body
    velocity of the constraint point (the rear axle centre at ``lever_b``) are zero."""
    v_b, h = body_velocity_rows(nav, w_b, np.zeros(3) if lever_b is None else lever_b)
    return Measurement(v_b[1:3].copy(), h[1:3].copy(), np.full(2, sigma_mps**2))


def odometer_update(
    nav: FloatArray,
    w_b: FloatArray,
    speed_mps: float,
    sigma_mps: float,
    lever_b: FloatArray | None = None,
) -> Measurement:
    """Odometer forward speed: v = v^b_x - speed, the first row of body_velocity_rows."""
    v_b, h = body_velocity_rows(nav, w_b, np.zeros(3) if lever_b is None else lever_b)
    return Measurement(np.array([v_b[0] - speed_mps]), h[0:1].copy(), np.array([sigma_mps**2]))


def zero_velocity_update(nav: FloatArray, sigma_mps: float) -> Measurement:
    """Zero velocity while static: v = v^n, H = [0, I, 0, 0, 0]."""
    h = np.zeros((3, N_BASE))
    h[:, VEL] = np.eye(3)
    return Measurement(nav[3:6].copy(), h, np.full(3, sigma_mps**2))
