"""Strapdown mechanization in the local-level ENU frame (paper 003 section 2.3, eq. (13)-(17)),
numba-compiled; docs/methods-ins.md gives every equation.

The navigation state of one epoch is a float array ``nav`` of ``NAV_SIZE`` values:
``[lat, lon, h, v_E, v_N, v_U, q_w, q_x, q_y, q_z]`` (rad, rad, m, m/s, attitude
quaternion body -> ENU). The IMU gives, per sample k, the increments over (t_{k-1}, t_k]:
``dtheta`` (rad) and ``dvel`` (m/s) in the body frame (x forward, y left, z up); the rates
form is turned into increments by :func:`increments_from_rates`.

One step (Shin 2005 / Savage 1998, as paper 003 cites [38]):

- attitude: body rotation vector with the two-sample coning correction
  phi_b = dth_k + (1/12) dth_{k-1} x dth_k; navigation-frame rotation zeta = omega_in^n dt;
  q_k = q(-zeta) * q_{k-1} * q(phi_b);
- velocity: dv_f^b = dv_k + 1/2 dth_k x dv_k + 1/6 dth_k x (dth_k x dv_k) (rotation, to
  second order) + 1/12 (dth_{k-1} x dv_k + dv_{k-1} x dth_k) (sculling);
  v_k = v_{k-1} + (I - 1/2 [zeta x]) C_b^n(k-1) dv_f^b + (g^n - (2 omega_ie^n +
  omega_en^n) x v) dt;
- position: trapezoidal velocity, h first, then latitude and longitude with the curvature
  radii at the mid-point.

The slowly varying terms (g, omega_ie, omega_en, Coriolis) are taken at t_{k-1}.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from coopproc.ins.earth import earth_rate_enu, normal_gravity, radii, transport_rate_enu
from coopproc.ins.quat import euler_to_quat, qmul, quat_to_dcm, quat_to_euler, rotvec_to_quat
from coopproc.model import FloatArray

__all__ = [
    "NAV_SIZE",
    "NavSolution",
    "increments_from_rates",
    "ins_step",
    "make_nav",
    "mechanize",
]

NAV_SIZE = 10


def make_nav(
    lat: float, lon: float, h: float, v_enu: FloatArray, roll: float, pitch: float, yaw: float
) -> FloatArray:
    """A ``nav`` array from geodetic position (rad, m), ENU velocity and Euler angles (rad)."""
    nav = np.empty(NAV_SIZE)
    nav[0], nav[1], nav[2] = lat, lon, h
    nav[3:6] = np.asarray(v_enu, dtype=np.float64)
    nav[6:10] = euler_to_quat(roll, pitch, yaw)
    return nav


def increments_from_rates(
    time_s: FloatArray, gyro_radps: FloatArray, accel_mps2: FloatArray, dt0: float | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(dt, dtheta, dvel) of rate samples: sample k stands for the interval (t_{k-1}, t_k].

    The rate of sample k is taken as the mean over its interval (what coopproc.io.imu_csv
    returns for increment files), so dtheta_k = omega_k dt_k, dv_k = f_k dt_k. The first
    sample's interval is ``dt0`` (default: the median interval).
    """
    t = np.asarray(time_s, dtype=np.float64)
    dt = np.empty_like(t)
    dt[1:] = np.diff(t)
    dt[0] = float(np.median(dt[1:])) if dt0 is None else dt0
    return dt, gyro_radps * dt[:, None], accel_mps2 * dt[:, None]


@numba.njit(cache=True)
def ins_step(
    nav: FloatArray,
    dth_prev: FloatArray,
    dv_prev: FloatArray,
    dth: FloatArray,
    dv: FloatArray,
    dt: float,
) -> None:
    """Advance ``nav`` (in place) by one IMU interval of length ``dt`` (s).

    ``dth``/``dv``: the (bias-compensated) increments of this interval; ``*_prev`` those of
    the previous one (zeros at the first step: no coning/sculling correction).
    """
    lat, h = nav[0], nav[2]
    v = nav[3:6].copy()
    q = nav[6:10].copy()
    w_ie = earth_rate_enu(lat)
    w_en = transport_rate_enu(lat, h, v)
    zeta = (w_ie + w_en) * dt
    # velocity: rotation + sculling corrections, paper 003 eq. (14)-(15)
    dvf = dv + 0.5 * np.cross(dth, dv) + (np.cross(dth_prev, dv) + np.cross(dv_prev, dth)) / 12.0
    dvf += np.cross(dth, np.cross(dth, dv)) / 6.0  # second-order rotation term
    c = quat_to_dcm(q)
    dvn = c @ dvf
    dvn = dvn - 0.5 * np.cross(zeta, dvn)
    g = normal_gravity(lat, h)
    cor = np.cross(2.0 * w_ie + w_en, v)
    v_new = v + dvn
    v_new[0] -= cor[0] * dt
    v_new[1] -= cor[1] * dt
    v_new[2] += (-g - cor[2]) * dt
    # position: trapezoidal velocity, paper 003 eq. (16)
    h_new = h + 0.5 * (v[2] + v_new[2]) * dt
    h_mid = 0.5 * (h + h_new)
    m, _ = radii(lat)
    lat_new = lat + 0.5 * (v[1] + v_new[1]) * dt / (m + h_mid)
    lat_mid = 0.5 * (lat + lat_new)
    _, n = radii(lat_mid)
    lon_new = nav[1] + 0.5 * (v[0] + v_new[0]) * dt / ((n + h_mid) * np.cos(lat_mid))
    # attitude: two-sample coning, body and navigation-frame rotation, paper 003 eq. (17)
    phi_b = dth + np.cross(dth_prev, dth) / 12.0
    q_new = qmul(qmul(rotvec_to_quat(-zeta), q), rotvec_to_quat(phi_b))
    q_new = q_new / np.sqrt(np.sum(q_new * q_new))
    nav[0], nav[1], nav[2] = lat_new, lon_new, h_new
    nav[3:6] = v_new
    nav[6:10] = q_new


@numba.njit(cache=True)
def _mechanize_loop(
    nav0: FloatArray, dt: FloatArray, dth: FloatArray, dv: FloatArray
) -> FloatArray:
    k = dt.shape[0]
    out = np.empty((k, NAV_SIZE))
    nav = nav0.copy()
    out[0] = nav
    for i in range(1, k):
        ins_step(nav, dth[i - 1], dv[i - 1], dth[i], dv[i], dt[i])
        out[i] = nav
    return out


@dataclass(frozen=True, eq=False)
class NavSolution:
    """INS solution per epoch: ``nav`` (K, NAV_SIZE) as :func:`ins_step` defines it."""

    time_s: FloatArray
    nav: FloatArray

    @property
    def llh(self) -> FloatArray:
        """(K, 3): latitude, longitude (rad), height (m)."""
        return self.nav[:, 0:3]

    @property
    def vel_enu(self) -> FloatArray:
        return self.nav[:, 3:6]

    @property
    def quat(self) -> FloatArray:
        return self.nav[:, 6:10]

    def euler(self) -> FloatArray:
        """(K, 3): roll, pitch, yaw (rad), quat.py's convention."""
        return np.array([quat_to_euler(q) for q in self.quat])


def mechanize(
    time_s: FloatArray, nav0: FloatArray, dtheta: FloatArray, dvel: FloatArray
) -> NavSolution:
    """Free-inertial solution from ``nav0`` at ``time_s[0]`` (compiled loop).

    ``dtheta``/``dvel`` (K, 3): increments of sample k over (t_{k-1}, t_k]; the first
    sample's increments only serve as the coning/sculling history of the second.
    """
    t = np.asarray(time_s, dtype=np.float64)
    dt = np.empty_like(t)
    dt[0] = 0.0
    dt[1:] = np.diff(t)
    out = _mechanize_loop(
        np.ascontiguousarray(nav0, dtype=np.float64),
        dt,
        np.ascontiguousarray(dtheta, dtype=np.float64),
        np.ascontiguousarray(dvel, dtype=np.float64),
    )
    return NavSolution(time_s=t, nav=out)
