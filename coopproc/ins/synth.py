"""Exact IMU increments of analytic trajectories (known answers for the mechanization,
and the seed of the IMU simulator of issue 12 item 6).

The trajectories are level (roll = pitch = 0) and given in the local-level ENU frame at
the start point; their specific force and angular rate include gravity (WGS-84 normal
gravity), earth rate and transport rate at the start latitude, so a correct
mechanization reproduces them. The increments of each interval are the 4-point
Gauss-Legendre quadrature of the closed-form rates (exact to rounding for intervals of
milliseconds). Approximation, documented in docs/methods-ins.md: the earth terms are
evaluated at the start latitude, which on a circle of radius R moves by R / 6.4e6 rad
(a 10 m circle: 1.6e-6 rad, an effect below 1e-4 m per lap).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.ins.earth import earth_rate_enu, normal_gravity, transport_rate_enu
from coopproc.ins.mechanize import make_nav
from coopproc.model import FloatArray

__all__ = ["SyntheticImu", "circle_imu", "straight_imu"]

_GL_X = np.array([-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526])
_GL_W = np.array([0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538])


@dataclass(frozen=True, eq=False)
class SyntheticImu:
    """Error-free IMU samples and the truth they come from.

    ``dtheta``/``dvel`` (K, 3): increments over (t_{k-1}, t_k] (row 0: over the interval
    before t_0, the same motion continued backwards); ``enu_m`` (K, 3) truth position in
    the ENU frame at the start point, ``vel_enu`` (K, 3), ``yaw`` (K,) rad; ``nav0`` the
    true initial ``nav`` array.
    """

    time_s: FloatArray
    dtheta: FloatArray
    dvel: FloatArray
    enu_m: FloatArray
    vel_enu: FloatArray
    yaw: FloatArray
    nav0: FloatArray


def circle_imu(
    lat: float,
    lon: float,
    h: float,
    radius_m: float,
    rate_radps: float,
    duration_s: float,
    dt_s: float = 0.005,
    yaw0: float = 0.0,
) -> SyntheticImu:
    """A level circle of ``radius_m`` at yaw rate ``rate_radps`` (counter-clockwise > 0)
    starting at (lat, lon, h) rad/m, heading ``yaw0``; ``radius_m = 0``: a turn in place.

    Truth: yaw chi = yaw0 + Omega t; v^n = V (cos chi, sin chi, 0), V = R Omega;
    a^n = V Omega (-sin chi, cos chi, 0); f^n = a^n + (2 w_ie + w_en) x v^n + (0, 0, g);
    f^b = Rz(chi)^T f^n; w_ib^b = Rz(chi)^T (w_ie + w_en) + (0, 0, Omega).
    """
    speed = radius_m * rate_radps
    k = round(duration_s / dt_s) + 1
    t = (np.arange(k) * dt_s).astype(np.float64)
    w_ie = earth_rate_enu(lat)
    g = normal_gravity(lat, h)

    def rates(tt: FloatArray) -> tuple[FloatArray, FloatArray]:
        chi = yaw0 + rate_radps * tt
        c, s = np.cos(chi), np.sin(chi)
        v = np.stack([speed * c, speed * s, np.zeros_like(tt)], axis=-1)
        a = np.stack([-speed * rate_radps * s, speed * rate_radps * c, np.zeros_like(tt)], -1)
        w_en = np.array([transport_rate_enu(lat, h, vi) for vi in v.reshape(-1, 3)])
        w_en = w_en.reshape(v.shape)
        f_n = a + np.cross(2.0 * w_ie + w_en, v)
        f_n[..., 2] += g
        w_n = w_ie + w_en
        f_b = np.stack([c * f_n[..., 0] + s * f_n[..., 1], -s * f_n[..., 0] + c * f_n[..., 1],
                        f_n[..., 2]], -1)  # fmt: skip
        w_b = np.stack([c * w_n[..., 0] + s * w_n[..., 1], -s * w_n[..., 0] + c * w_n[..., 1],
                        w_n[..., 2] + rate_radps], -1)  # fmt: skip
        return w_b, f_b

    nodes = (t - 0.5 * dt_s)[:, None] + 0.5 * dt_s * _GL_X[None, :]
    w_b, f_b = rates(nodes)
    dtheta = 0.5 * dt_s * np.einsum("j,kjc->kc", _GL_W, w_b)
    dvel = 0.5 * dt_s * np.einsum("j,kjc->kc", _GL_W, f_b)
    chi = (yaw0 + rate_radps * t).astype(np.float64)
    if rate_radps == 0.0:
        enu = np.zeros((k, 3))
    else:
        enu = np.stack([radius_m * (np.sin(chi) - np.sin(yaw0)),
                        -radius_m * (np.cos(chi) - np.cos(yaw0)), np.zeros(k)], -1)  # fmt: skip
    vel = np.stack([speed * np.cos(chi), speed * np.sin(chi), np.zeros(k)], -1)
    nav0 = make_nav(lat, lon, h, vel[0], 0.0, 0.0, yaw0)
    return SyntheticImu(t, dtheta, dvel, enu, vel, chi, nav0)


def straight_imu(
    lat: float, lon: float, h: float, speed_mps: float, duration_s: float, dt_s: float = 0.005
) -> SyntheticImu:
    """A level drive due east at constant ``speed_mps`` along the parallel of ``lat``.

    Exact on the ellipsoid: v^n = (V, 0, 0) and the attitude (yaw 0) are constant in the
    local-level frame, so f^b = (2 w_ie + w_en) x v^n + (0, 0, g) and w_ib^b = w_ie + w_en
    are constant. ``enu_m`` holds (V t, 0, 0): the along-track distance and no cross-track.
    """
    k = round(duration_s / dt_s) + 1
    t = (np.arange(k) * dt_s).astype(np.float64)
    v = np.array([speed_mps, 0.0, 0.0])
    w_ie = earth_rate_enu(lat)
    w_en = transport_rate_enu(lat, h, v)
    f_b = np.cross(2.0 * w_ie + w_en, v) + np.array([0.0, 0.0, normal_gravity(lat, h)])
    w_b = w_ie + w_en
    enu = np.zeros((k, 3))
    enu[:, 0] = speed_mps * t
    vel = np.tile(v, (k, 1))
    nav0 = make_nav(lat, lon, h, v, 0.0, 0.0, 0.0)
    return SyntheticImu(
        t, np.tile(w_b * dt_s, (k, 1)), np.tile(f_b * dt_s, (k, 1)), enu, vel, np.zeros(k), nav0
    )
