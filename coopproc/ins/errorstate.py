"""The error-state EKF of the INS (paper 003 section 2.4, eq. (18)-(22); paper 002 eq.
(1)-(5)): psi-angle error model, first-order Gauss-Markov sensor errors, discretization,
closed-loop feedback (docs/methods-ins.md).

Error state (``N_BASE`` = 15, or 21 with scale factors), all in the local-level ENU frame:
``dr`` position error (m, INS minus true), ``dv`` velocity error (m/s), ``psi`` attitude
error (rad; computed C_b^p = (I - [psi x]) C_b^c), ``bg`` gyro bias (rad/s), ``ba``
accelerometer bias (m/s^2), optionally ``sg``/``sa`` scale factors (dimensionless).
Measurement models are in :mod:`coopproc.ins.updates`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coopproc.estimation.robust import igg3_scalar
from coopproc.ins.earth import (
    earth_rate_enu,
    ecef_to_enu_matrix,
    llh_to_ecef,
    normal_gravity,
    radii,
    transport_rate_enu,
)
from coopproc.ins.models import ImuFigures
from coopproc.ins.quat import qmul, quat_to_dcm, rotvec_to_quat, skew
from coopproc.model import FloatArray

__all__ = [
    "ATT",
    "BA",
    "BG",
    "N_BASE",
    "POS",
    "SA",
    "SG",
    "VEL",
    "ErrorStateEkf",
    "Measurement",
    "apply_correction",
    "discretize",
    "f_matrix",
    "inject_error",
    "level_correlated",
    "nav_error",
    "process_noise",
]

POS, VEL, ATT, BG, BA, SG, SA = (slice(3 * i, 3 * i + 3) for i in range(7))
N_BASE = 15


def f_matrix(
    nav: FloatArray, f_b: FloatArray, w_b: FloatArray, tau_s: float, n_states: int = N_BASE
) -> FloatArray:
    """Continuous F of the psi-angle error model (paper 003 eq. (20)-(22), paper 002 eq.
    (1)-(3)) with Gauss-Markov sensor errors (paper 003 eq. (19)):

    d(dr)/dt = -[w_en x] dr + dv
    d(dv)/dt = [f^n x] psi - [(2 w_ie + w_en) x] dv + (2 g / R) dr_U e_U + C ba (+ C diag(f^b) sa)
    d(psi)/dt = -[(w_ie + w_en) x] psi - C bg (- C diag(w^b) sg)
    d(b)/dt = -b / tau (biases and scale factors)

    ``f_b``/``w_b``: the compensated specific force and rate of the interval (body).
    """
    lat, h = nav[0], nav[2]
    c = quat_to_dcm(nav[6:10])
    w_ie = earth_rate_enu(lat)
    w_en = transport_rate_enu(lat, h, nav[3:6])
    m, n = radii(lat)
    f = np.zeros((n_states, n_states))
    f[POS, POS] = -skew(w_en)
    f[POS, VEL] = np.eye(3)
    f[VEL, ATT] = skew(c @ f_b)
    f[VEL, VEL] = -skew(2.0 * w_ie + w_en)
    f[5, 2] = 2.0 * normal_gravity(lat, h) / (np.sqrt(m * n) + h)
    f[VEL, BA] = c
    f[ATT, ATT] = -skew(w_ie + w_en)
    f[ATT, BG] = -c
    for i in range(9, n_states):
        f[i, i] = -1.0 / tau_s
    if n_states > N_BASE:
        f[ATT, SG] = -c * w_b[None, :]
        f[VEL, SA] = c * f_b[None, :]
    return f


def discretize(f: FloatArray, dt: float) -> FloatArray:
    """Phi = I + F dt + 1/2 (F dt)^2 (second-order series of exp(F dt))."""
    fdt = f * dt
    return np.eye(f.shape[0]) + fdt + 0.5 * fdt @ fdt


def process_noise(noise: ImuFigures, phi: FloatArray, dt: float) -> FloatArray:
    """Q_k = 1/2 (Phi Q_c Phi^T + Q_c) dt (trapezoid) with the continuous densities:
    VRW^2 on dv, ARW^2 on psi (isotropic, so C Q C^T = Q), 2 sigma^2 / tau on the
    Gauss-Markov states."""
    n = phi.shape[0]
    q_bg, q_ba = noise.bias_psd()
    qc = np.zeros(n)
    qc[VEL] = noise.vrw_mps_rts**2
    qc[ATT] = noise.arw_rad_rts**2
    qc[BG] = q_bg
    qc[BA] = q_ba
    if n > N_BASE:
        qc[SG] = 2.0 * (noise.gyro_scale * 1e-6) ** 2 / noise.correlation_time
        qc[SA] = 2.0 * (noise.accel_scale * 1e-6) ** 2 / noise.correlation_time
    q = 0.5 * (phi * qc[None, :]) @ phi.T
    q[np.diag_indices(n)] += 0.5 * qc
    return q * dt


def _frame_angle(nav: FloatArray, dr: FloatArray) -> FloatArray:
    """delta theta: the local-level frame at the INS position rotated against the true one
    by a position error dr (ENU, m): (-dr_N/(M+h), dr_E/(N+h), dr_E tan(lat)/(N+h))."""
    m, n = radii(nav[0])
    h = nav[2]
    return np.array([-dr[1] / (m + h), dr[0] / (n + h), dr[0] * np.tan(nav[0]) / (n + h)])


def apply_correction(nav: FloatArray, dx: FloatArray) -> FloatArray:
    """The corrected nav (a new array): r - dr, v - dv, q <- q(phi) * q with
    phi = psi + delta theta (the attitude error against the true frame)."""
    out = nav.copy()
    m, n = radii(nav[0])
    h = nav[2]
    out[0] = nav[0] - dx[1] / (m + h)
    out[1] = nav[1] - dx[0] / ((n + h) * np.cos(nav[0]))
    out[2] = h - dx[2]
    out[3:6] = nav[3:6] - dx[VEL]
    phi = dx[ATT] + _frame_angle(nav, dx[POS])
    q = qmul(rotvec_to_quat(phi), nav[6:10])
    out[6:10] = q / np.linalg.norm(q)
    return out


def inject_error(nav: FloatArray, dx: FloatArray) -> FloatArray:
    """The INS nav whose error against the true ``nav`` is ``dx`` (the inverse of
    :func:`apply_correction` to first order); used to test the Jacobians."""
    out = nav.copy()
    m, n = radii(nav[0])
    h = nav[2]
    out[0] = nav[0] + dx[1] / (m + h)
    out[1] = nav[1] + dx[0] / ((n + h) * np.cos(nav[0]))
    out[2] = h + dx[2]
    out[3:6] = nav[3:6] + dx[VEL]
    phi = dx[ATT] + _frame_angle(nav, dx[POS])
    out[6:10] = qmul(rotvec_to_quat(-phi), nav[6:10])
    return out


def nav_error(nav_ins: FloatArray, nav_true: FloatArray) -> FloatArray:
    """The navigation part (9 values: dr, dv, psi) of the error of ``nav_ins`` against
    ``nav_true``: dr in ENU at the true position (through ECEF), psi = phi - delta theta."""
    c_en = ecef_to_enu_matrix(nav_true[0], nav_true[1])
    dr = c_en @ (llh_to_ecef(*nav_ins[0:3]) - llh_to_ecef(*nav_true[0:3]))
    q_true_conj = nav_true[6:10] * np.array([1.0, -1.0, -1.0, -1.0])
    dq = qmul(nav_ins[6:10], q_true_conj)  # q(-phi)
    phi = -2.0 * dq[1:4] * np.sign(dq[0])
    return np.concatenate([dr, nav_ins[3:6] - nav_true[3:6], phi - _frame_angle(nav_true, dr)])


def level_correlated(p0: FloatArray, c_bn: FloatArray, g: float) -> FloatArray:
    """P0 of a start levelled at rest: the levelling absorbs the horizontal accelerometer
    bias into the tilt, so psi_E = -(C ba)_N / g + e, psi_N = (C ba)_E / g + e (the
    horizontal specific-force error -psi x g + C ba is zero after levelling). With
    ``p0``'s diagonal: psi = J ba + e, Var(e) = Var(psi) - (J Var(ba) J^T) (at least 0),
    so P_psi,psi = J P_ba J^T + Var(e) and P_psi,ba = J P_ba. Without this the filter
    holds the level to the noise part and spends a turn's lateral acceleration on the
    heading and gyro bias instead (docs/methods-ins.md, "Error-state model")."""
    p = np.array(p0, dtype=np.float64)
    j = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) @ c_bn / g
    p_ba = p[BA, BA]
    jpj = j @ p_ba @ j.T
    var_e = np.maximum(np.diag(p[ATT, ATT]) - np.diag(jpj), 0.0)
    var_e[2] = p[8, 8]
    p[ATT, ATT] = jpj + np.diag(var_e)
    p[ATT, BA] = j @ p_ba
    p[BA, ATT] = p[ATT, BA].T
    return p


@dataclass(frozen=True, eq=False)
class Measurement:
    """Innovations ``v`` = predicted - measured (m,), design ``h`` (m, 15), variances ``r``."""

    v: FloatArray
    h: FloatArray
    r: FloatArray


@dataclass(eq=False)
class ErrorStateEkf:
    """Closed-loop error-state filter: the sensor-error estimates live here, the INS
    solution in the caller's ``nav`` array, corrected in :meth:`feedback`."""

    noise: ImuFigures
    p: FloatArray
    x: FloatArray = field(init=False)
    bias_g: FloatArray = field(default_factory=lambda: np.zeros(3))
    bias_a: FloatArray = field(default_factory=lambda: np.zeros(3))
    scale_g: FloatArray = field(default_factory=lambda: np.zeros(3))
    scale_a: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        self.x = np.zeros(self.p.shape[0])

    @classmethod
    def start(
        cls,
        noise: ImuFigures,
        sigma_pos: FloatArray,
        sigma_vel: FloatArray,
        sigma_att: FloatArray,
        scale_factors: bool = False,
    ) -> ErrorStateEkf:
        """P0 from the initial 1-sigma figures and the grade's bias (and scale) sigmas."""
        sig = [sigma_pos, sigma_vel, sigma_att]
        sig += [np.full(3, noise.gyro_bias0_radps), np.full(3, noise.accel_bias0_mps2)]
        if scale_factors:
            sig += [np.full(3, noise.gyro_scale * 1e-6), np.full(3, noise.accel_scale * 1e-6)]
        s = np.concatenate([np.broadcast_to(np.asarray(v, dtype=np.float64), 3) for v in sig])
        return cls(noise, np.diag(s**2))

    @property
    def n(self) -> int:
        return int(self.p.shape[0])

    def compensate(
        self, dth: FloatArray, dv: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """Increments corrected by the estimated biases (and scale factors)."""
        return (dth - self.bias_g * dt) / (1.0 + self.scale_g), (dv - self.bias_a * dt) / (
            1.0 + self.scale_a
        )

    def propagate(self, nav: FloatArray, dth_c: FloatArray, dv_c: FloatArray, dt: float) -> None:
        """Time update over ``dt`` with the compensated increments of that interval
        (paper 002 eq. (12)-(13)): x = Phi x, P = Phi P Phi^T + Q."""
        f = f_matrix(nav, dv_c / dt, dth_c / dt, self.noise.correlation_time, self.n)
        phi = discretize(f, dt)
        self.x = phi @ self.x
        p = phi @ self.p @ phi.T + process_noise(self.noise, phi, dt)
        self.p = 0.5 * (p + p.T)

    def update(self, meas: Measurement, robust: tuple[float, float] | None = None) -> FloatArray:
        """Measurement update (paper 002 eq. (14)-(17)) as sequential scalar updates; with
        ``robust`` = (k0, k1) each innovation gets the IGG-III factor (eq. (18)-(19)) of
        its standardized value against H P H^T + R. Returns the factors gamma."""
        gammas = np.ones(meas.v.shape[0])
        for i in range(meas.v.shape[0]):
            h = np.zeros(self.n)
            h[: meas.h.shape[1]] = meas.h[i]
            innov = meas.v[i] - h @ self.x
            ph = self.p @ h
            s = h @ ph + meas.r[i]
            if robust is not None:
                gammas[i] = igg3_scalar(innov / np.sqrt(s), robust[0], robust[1])
                s = h @ ph + meas.r[i] / gammas[i]
            g = ph / s
            self.x = self.x + g * innov
            p = self.p - np.outer(g, ph)
            self.p = 0.5 * (p + p.T)
        return gammas

    def feedback(self, nav: FloatArray) -> FloatArray:
        """Closed loop: the corrected nav; the sensor errors go to the estimates; x = 0."""
        out = apply_correction(nav, self.x)
        self.bias_g = self.bias_g + self.x[BG]
        self.bias_a = self.bias_a + self.x[BA]
        if self.n > N_BASE:
            self.scale_g = self.scale_g + self.x[SG]
            self.scale_a = self.scale_a + self.x[SA]
        self.x = np.zeros(self.n)
        return out
