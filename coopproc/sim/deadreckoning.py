"""Follower navigation: INS/odometer dead reckoning with drifting heading and odometer errors.

The true path is cut into the nav-rate steps (Delta L_k, course theta_k) that paper 004
eq. (3) integrates; the simulated INS/OD measures them with

- heading error  dpsi(t) = dpsi_0 + b t + ARW random walk   (gyro bias b, Bynav-A1 < 2.7 deg/h)
- distance       Delta L_k (1 + k_s) + n_k,  n_k ~ N(0, q^2 Delta L_k)   (scale factor, noise)

and integrates x_k = x_0 + e_0 + sum Delta L_i (sin(theta_i + dpsi_i), cos(theta_i + dpsi_i))
(east, north; heading clockwise from north). The error therefore grows with time and
distance as real DR does: a constant heading error rotates the travelled displacement,
the bias term adds ~ v b t^2 / 2 of cross-track error on a straight run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.model import FloatArray
from coopproc.sim.params import SimParams

__all__ = ["DrErrors", "course_rad", "dead_reckon", "dr_drift_sigma_mps", "draw_dr_errors"]

_DPH = np.pi / 180.0 / 3600.0  # deg/h -> rad/s


@dataclass(frozen=True)
class DrErrors:
    """The sensor errors one follower drew (recorded in the truth)."""

    gyro_bias_dph: float
    odo_scale: float
    heading_init_deg: float
    init_error_m: tuple[float, float, float]


def draw_dr_errors(params: SimParams, rng: np.random.Generator) -> DrErrors:
    """Draw one follower's errors from the configured figures."""
    magnitude = params.gyro_bias_dph * rng.uniform(0.5, 1.0)
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    e0 = rng.normal(0.0, params.init_error_m, size=2)
    up0 = rng.normal(0.0, params.init_error_m / 2.0)
    return DrErrors(
        gyro_bias_dph=float(sign * magnitude),
        odo_scale=float(rng.normal(0.0, params.odo_scale_sigma)),
        heading_init_deg=float(rng.normal(0.0, params.heading_init_sigma_deg)),
        init_error_m=(float(e0[0]), float(e0[1]), float(up0)),
    )


def course_rad(enu_m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Step lengths (n-1) and courses (n-1, rad clockwise from north) of a trajectory.

    Steps without horizontal motion keep the course of the previous moving step (the
    first ones take the first moving step's course).
    """
    d = np.diff(enu_m[:, :2], axis=0)
    step = np.hypot(d[:, 0], d[:, 1])
    course = np.arctan2(d[:, 0], d[:, 1])
    moving = step > 1e-9
    if not moving.any():
        return step, np.zeros_like(step)
    idx = np.where(moving, np.arange(step.shape[0]), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = int(np.argmax(moving))
    return step, course[idx]


def dead_reckon(
    truth_enu_m: FloatArray,
    time_s: FloatArray,
    params: SimParams,
    errors: DrErrors,
    rng: np.random.Generator,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Dead-reckoned (n, 3) positions, (n,) heading deg and (n, 3) 1-sigma of a follower."""
    n = truth_enu_m.shape[0]
    step, course = course_rad(truth_enu_m)
    t_rel = time_s - time_s[0]
    dt = np.diff(time_s)
    arw = params.gyro_arw_dpsh * np.pi / 180.0 / 60.0  # deg/sqrt(h) -> rad/sqrt(s)
    walk = np.concatenate(([0.0], np.cumsum(rng.normal(0.0, 1.0, size=n - 1) * arw * np.sqrt(dt))))
    dpsi = np.deg2rad(errors.heading_init_deg) + errors.gyro_bias_dph * _DPH * t_rel + walk
    noise = rng.normal(0.0, 1.0, size=n - 1) * params.odo_noise_m * np.sqrt(step)
    measured = step * (1.0 + errors.odo_scale) + noise
    heading = course + dpsi[:-1]
    out = np.empty_like(truth_enu_m)
    out[0, :2] = truth_enu_m[0, :2] + np.asarray(errors.init_error_m[:2])
    out[1:, 0] = out[0, 0] + np.cumsum(measured * np.sin(heading))
    out[1:, 1] = out[0, 1] + np.cumsum(measured * np.cos(heading))
    up_walk = np.concatenate(
        ([0.0], np.cumsum(rng.normal(0.0, 1.0, size=n - 1) * params.height_rw_m * np.sqrt(dt)))
    )
    out[:, 2] = truth_enu_m[:, 2] + errors.init_error_m[2] + up_walk
    heading_deg = np.mod(np.rad2deg(np.concatenate((heading, heading[-1:]))), 360.0)
    # 1-sigma from the configured figures: initial error, odometer noise and scale over the
    # distance s travelled, and the heading drift acting on it (bias bound, ARW).
    s = np.concatenate(([0.0], np.cumsum(step)))
    heading_sigma = np.sqrt(
        np.deg2rad(params.heading_init_sigma_deg) ** 2
        + (params.gyro_bias_dph * _DPH * t_rel / 2.0) ** 2
        + arw**2 * t_rel
    )
    sigma_h = np.sqrt(
        params.init_error_m**2
        + 0.5 * params.odo_noise_m**2 * s
        + 0.5 * (params.odo_scale_sigma * s) ** 2
        + 0.5 * (heading_sigma * s) ** 2
    )
    sigma_up = np.sqrt((params.init_error_m / 2.0) ** 2 + params.height_rw_m**2 * t_rel)
    sigma = np.column_stack((sigma_h, sigma_h, sigma_up))
    return out, heading_deg, sigma


def dr_drift_sigma_mps(params: SimParams) -> float:
    """Declared drift_sigma of a follower: 1-sigma of the 1-s position increment error, m/s.

    From the figures: odometer noise over the metres of one second, scale error times
    speed, and the mid-session heading error (bias bound) times speed.
    """
    v = params.speed_mps
    heading = np.hypot(
        np.deg2rad(params.heading_init_sigma_deg),
        params.gyro_bias_dph * _DPH * params.duration_s / 2.0,
    )
    return float(
        np.sqrt(params.odo_noise_m**2 * v + (params.odo_scale_sigma * v) ** 2 + (heading * v) ** 2)
    )
