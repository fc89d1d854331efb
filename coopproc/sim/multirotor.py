"""The ``quadrotor`` scenario (issue 31 part 3): drones with a consumer MEMS IMU flying in
a lab among six anchors they range one at a time, no navigation file, no static start;
and the body kinematics of a multirotor for its IMU (:func:`multirotor_imu`).

- **Lab**: six anchors on stands and walls around a 6.5 x 7 m flight area
  (:data:`LAB_SITES`): the horizontal layout of the shared MiLUV session's anchors
  (miluv1/session.toml, rounded), their heights alternating 0.3-0.5 m and 2.5-2.7 m (a
  lab that wants the height observable; MiLUV's own are 1.6-1.9 m).
- **Flight**: each drone (``ifo001``.. ``ifo003``, 1-3 of them) flies a 3-D Lissajous
  curve around a centre of its own, +-1.4 m horizontally at ``speed_mps`` / 1.4 rad/s
  (frequency ratios and phases drawn per drone and seed), 1.3 m +- 0.4 m high; the log
  starts in flight (the velocity at the first sample is not zero). Its yaw is its own:
  a drawn start yaw plus a +-0.6 rad swing of period 25 s, not the course.
- **Ranging**: a TDMA round: each drone polls its anchors in turn, one range every
  period / 6 (2 Hz at the default 1/3 Hz per pair, one range per anchor every 3 s); the
  drones are interleaved by period / 18 (the network's 6 Hz). No epoch has two anchors
  of one drone: the least-squares fixes need a window, the INS takes each range alone.
- **IMU** (``imu_body = "multirotor"``, :func:`multirotor_imu`): the body's z axis along
  the thrust, i.e. the specific force f^n = a^n + g e_U (+ Coriolis), its x axis the yaw
  direction projected normal to z; gyro = the body rate from the attitude's derivative
  (central difference of C_b^n over 1 ms, exact to 1e-7 rad/s here) + the earth rate;
  accelerometer = C_n^b f^n = (0, 0, |f|) (a drag-free multirotor senses its thrust
  only). Written: ``imu_<ID>.csv``; no odometer, ``nhc = false``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from coopproc.errors import ConfigError
from coopproc.model import FloatArray
from coopproc.sim.params import NlosSpec, SimParams
from coopproc.sim.scenario_types import Actor, World, named_rng
from coopproc.sim.uwb import PairModel

__all__ = ["LAB_SITES", "QUADROTOR_DEFAULTS", "multirotor_attitude", "multirotor_imu", "quadrotor"]

#: Anchors (east, north, up), m: MiLUV's horizontal layout, heights alternating low/high.
LAB_SITES: tuple[tuple[float, float, float], ...] = (
    (3.3, 3.5, 2.6), (3.2, 0.3, 0.4), (2.9, -2.9, 2.5),
    (-2.5, -3.5, 0.5), (-3.0, 0.6, 2.7), (-2.7, 3.7, 0.3),
)  # fmt: skip
#: Centres of the drones' curves (east, north), m.
_CENTRES = ((-0.6, 0.4), (0.6, -0.4), (0.0, 0.6))
#: Horizontal amplitude (m), mean height and its amplitude (m), yaw swing (rad, period s).
_AMPLITUDE_M, _HEIGHT_M, _HEIGHT_AMP_M = 1.4, 1.3, 0.4
_YAW_SWING_RAD, _YAW_PERIOD_S = 0.6, 25.0


def quadrotor(params: SimParams, seed: int, t: FloatArray) -> World:
    """1-3 drones (platforms - 6) among the six lab anchors (module docstring)."""
    n_anchor = len(LAB_SITES)
    drones = params.platforms - n_anchor
    if not 1 <= drones <= len(_CENTRES):
        raise ConfigError(
            f"quadrotor: platforms must be 7..9 (1-3 drones + {n_anchor} anchors), "
            f"found {params.platforms}"
        )
    omega = params.speed_mps / _AMPLITUDE_M
    period = 1.0 / params.range_rate_hz
    slot = period / n_anchor
    actors: list[Actor] = []
    links: list[PairModel] = []
    for d in range(drones):
        pid = f"ifo{d + 1:03d}"
        rng = named_rng(seed, pid)
        ratio = rng.uniform(1.2, 1.6)
        ph = rng.uniform(0.0, 2.0 * np.pi, 4)
        ce, cn = _CENTRES[d]
        pos = np.column_stack(
            [
                ce + _AMPLITUDE_M * np.sin(omega * t + ph[0]),
                cn + _AMPLITUDE_M * np.sin(ratio * omega * t + ph[1]),
                _HEIGHT_M + _HEIGHT_AMP_M * np.sin(0.3 * omega * t + ph[2]),
            ]
        )
        yaw0 = rng.uniform(-np.pi, np.pi)
        yaw = yaw0 + _YAW_SWING_RAD * np.sin(2.0 * np.pi * t / _YAW_PERIOD_S + ph[3])
        actors.append(Actor(pid, "tag", "none", pos, yaw_rad=yaw))
        for j in range(n_anchor):
            offset = round(j * slot + d * slot / len(_CENTRES), 6)
            links.append(PairModel(pid, f"AN{j + 1}", offset_s=offset))
    for j, site in enumerate(LAB_SITES):
        xyz = np.array(site, dtype=np.float64)
        actors.append(Actor(f"AN{j + 1}", "anchor", "none", np.tile(xyz, (t.shape[0], 1))))
    return World(time_rel_s=t, actors=tuple(actors), links=tuple(links))


def multirotor_attitude(f_n: FloatArray, yaw: FloatArray) -> FloatArray:
    """(n, 3, 3) C_b^n of a multirotor: z_b along the specific force ``f_n`` (n, 3, ENU),
    x_b the direction of ``yaw`` (rad, counter-clockwise from east) made normal to z_b,
    y_b = z_b x x_b (body x forward, y left, z up)."""
    z = f_n / np.linalg.norm(f_n, axis=1, keepdims=True)
    e = np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)])
    x = e - np.sum(e * z, axis=1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)


def multirotor_imu(
    spline: CubicSpline,
    yaw_spline: CubicSpline,
    time_s: FloatArray,
    gravity: Any,
    w_ie: FloatArray | None,
    interval_s: float = 0.0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(gyro rad/s, accel m/s^2, C_b^n) of the multirotor along ``spline`` (positions) with
    ``yaw_spline`` (rad); ``gravity(up_m)`` the normal gravity, ``w_ie`` the earth rate
    (ENU) or None (module docstring). A sample at t stands for the interval
    (t - ``interval_s``, t] (the IMU files' convention, coopproc.ins.mechanize): its rates
    are those of the interval's middle (its mean to second order); C_b^n is at t. (Rates
    at t itself lead the attitude by half a sample: 1e-4 rad of tilt at 200 Hz, 2.5 m of
    free-inertial drift in 60 s of this flight.)"""

    def attitude(tk: FloatArray) -> tuple[FloatArray, FloatArray]:
        p, v, a = spline(tk), spline(tk, 1), spline(tk, 2)
        f = a.copy()
        f[:, 2] += gravity(p[:, 2])
        if w_ie is not None:
            f += 2.0 * np.cross(w_ie, v)
        return multirotor_attitude(f, yaw_spline(tk)), f

    h = 1e-3
    c, _ = attitude(time_s)
    mid = time_s - 0.5 * interval_s
    c_mid, f_n = attitude(mid)
    c_minus, _ = attitude(mid - h)
    c_plus, _ = attitude(mid + h)
    r = np.einsum("kji,kjl->kil", c_minus, c_plus)  # C(t-h)^T C(t+h): body rotation over 2h
    gyro = 0.5 * np.column_stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0],
                                  r[:, 1, 0] - r[:, 0, 1]]) / (2.0 * h)  # fmt: skip
    if w_ie is not None:
        gyro += np.einsum("kji,j->ki", c_mid, w_ie)
    accel = np.einsum("kji,kj->ki", c_mid, f_n)
    return gyro, accel, c


#: quadrotor defaults: 120 s, 3 drones + 6 anchors, 0.8 m/s, ranges at 1/3 Hz per pair
#: (2 Hz per drone), MiLUV's range noise (0.093 m declared there; 0.1 m here), consumer
#: IMU at 200 Hz, two short NLOS bursts (obstacles in the lab) on ifo001 (there with any
#: number of drones).
QUADROTOR_DEFAULTS: dict[str, Any] = {
    "duration_s": 120.0,
    "platforms": 9,
    "speed_mps": 0.8,
    "range_rate_hz": 1.0 / 3.0,
    "uwb_noise_m": 0.1,
    "imu_rate_hz": 200.0,
    "imu_grade": "consumer",
    "imu_body": "multirotor",
    "nlos_events": (
        NlosSpec("AN2-ifo001", 40.0, 50.0, 0.4),
        NlosSpec("AN5-ifo001", 70.0, 80.0, 0.5),
    ),
}
