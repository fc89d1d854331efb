"""Coarse alignment from a static start (paper 003 section 2.1, eq. (1)-(5)): levelling
from the mean specific force, heading by gyrocompassing when the gyro can resolve the
earth rate, otherwise from a given heading or the first motion of a position source.

Conventions of coopproc.ins.quat (ENU, body x forward, y left, z up; yaw counter-clockwise
from east). At rest f^b = C_n^b (0, 0, g) and omega^b = C_n^b omega_ie^n, so
roll = atan2(f_y, f_z), pitch = atan2(-f_x, sqrt(f_y^2 + f_z^2)) and, with the levelled
rate omega^l = Ry(pitch) Rx(roll) omega^b, yaw = atan2(omega^l_x, omega^l_y).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from coopproc.errors import StageError
from coopproc.frames import EARTH_RATE_RADPS
from coopproc.ins.earth import normal_gravity
from coopproc.ins.models import ImuFigures
from coopproc.model import FloatArray

__all__ = [
    "Alignment",
    "coarse_align",
    "gyrocompass",
    "gyrocompass_sigma",
    "heading_from_motion",
    "level",
    "static_start",
]


@dataclass(frozen=True)
class Alignment:
    """Initial attitude (rad) and where its heading came from, with 1-sigma figures."""

    roll: float
    pitch: float
    yaw: float
    heading_source: Literal["gyrocompass", "given", "motion", "search"]
    sigma_level: float
    sigma_yaw: float
    static_samples: int


def static_start(
    time_s: FloatArray,
    gyro_radps: FloatArray,
    accel_mps2: FloatArray,
    window_s: float = 1.0,
    accel_std: float = 0.05,
    gyro_std: float = 0.01,
) -> int:
    """Samples of the static interval at the start (0 when the first window moves).

    Windows of ``window_s`` from the first sample are static while every accelerometer
    axis scatters less than ``accel_std`` (m/s^2), every gyro axis less than ``gyro_std``
    (rad/s) and the mean specific force is within 2 % of 9.8 m/s^2; the static start ends
    at the first window that is not.
    """
    t = np.asarray(time_s, dtype=np.float64)
    edges = np.searchsorted(t, t[0] + window_s * np.arange(1, int((t[-1] - t[0]) / window_s) + 1))
    start = 0
    for end in edges:
        if end - start < 2:
            break
        f = accel_mps2[start:end]
        w = gyro_radps[start:end]
        g_ok = abs(float(np.linalg.norm(f.mean(axis=0))) - 9.8) < 0.02 * 9.8
        if not (g_ok and f.std(axis=0).max() < accel_std and w.std(axis=0).max() < gyro_std):
            break
        start = int(end)
    return start


def level(f_mean: FloatArray) -> tuple[float, float]:
    """(roll, pitch) rad from the mean specific force at rest (body frame, m/s^2)."""
    fx, fy, fz = (float(v) for v in f_mean)
    return float(np.arctan2(fy, fz)), float(np.arctan2(-fx, np.hypot(fy, fz)))


def gyrocompass(w_mean: FloatArray, roll: float, pitch: float) -> float:
    """yaw (rad, ENU) from the mean gyro rate at rest and the levelled attitude."""
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    w_l = ry @ rx @ np.asarray(w_mean, dtype=np.float64)
    return float(np.arctan2(w_l[0], w_l[1]))


def gyrocompass_sigma(lat: float, noise: ImuFigures, duration_s: float) -> float:
    """1-sigma heading (rad) of gyrocompassing: sqrt(b^2 + ARW^2 / T) / (Omega cos lat),
    b the whole gyro bias (turn-on and instability)."""
    sigma_w = np.hypot(noise.gyro_bias0_radps, noise.arw_rad_rts / np.sqrt(max(duration_s, 1e-9)))
    horizontal = EARTH_RATE_RADPS * abs(np.cos(lat))
    return float(sigma_w / horizontal) if horizontal > 0 else float("inf")


def heading_from_motion(
    time_s: FloatArray, enu_m: FloatArray, min_distance_m: float = 2.0
) -> tuple[float, float]:
    """(time, yaw rad) of the first displacement of at least ``min_distance_m`` from the
    first position (horizontal): the direction of travel, taken as the body's heading
    (a vehicle that starts forward without turning)."""
    d = np.asarray(enu_m, dtype=np.float64)[:, :2] - np.asarray(enu_m)[0, :2]
    far = np.flatnonzero(np.hypot(d[:, 0], d[:, 1]) >= min_distance_m)
    if far.size == 0:
        raise StageError(f"heading from motion: the positions never move {min_distance_m} m")
    k = int(far[0])
    return float(time_s[k]), float(np.arctan2(d[k, 1], d[k, 0]))


def coarse_align(
    time_s: FloatArray,
    gyro_radps: FloatArray,
    accel_mps2: FloatArray,
    lat: float,
    noise: ImuFigures,
    *,
    yaw: float | None = None,
    motion: tuple[FloatArray, FloatArray] | None = None,
    min_static_s: float = 5.0,
    max_yaw_sigma: float = np.radians(3.0),
) -> Alignment:
    """Align from the static start of the samples.

    Heading: ``yaw`` when given; else gyrocompassing when its predicted 1-sigma is below
    ``max_yaw_sigma``; else the first motion of ``motion`` = (time_s, enu_m); else
    StageError naming what is missing.
    """
    n = static_start(time_s, gyro_radps, accel_mps2)
    duration = float(time_s[n - 1] - time_s[0]) if n > 1 else 0.0
    if duration < min_static_s:
        raise StageError(
            f"alignment: the IMU is static for {duration:.1f} s at the start, "
            f"{min_static_s:.0f} s needed for levelling"
        )
    roll, pitch = level(accel_mps2[:n].mean(axis=0))
    g = normal_gravity(lat, 0.0)
    # the whole accelerometer bias (turn-on and instability) tilts the levelled frame
    sigma_level = float(np.hypot(noise.accel_bias0_mps2, noise.vrw_mps_rts / np.sqrt(duration)) / g)
    sigma_gc = gyrocompass_sigma(lat, noise, duration)
    if yaw is not None:
        return Alignment(roll, pitch, float(yaw), "given", sigma_level, np.radians(1.0), n)
    if sigma_gc <= max_yaw_sigma:
        psi = gyrocompass(gyro_radps[:n].mean(axis=0), roll, pitch)
        return Alignment(roll, pitch, psi, "gyrocompass", sigma_level, sigma_gc, n)
    if motion is not None:
        _, psi = heading_from_motion(*motion)
        return Alignment(roll, pitch, psi, "motion", sigma_level, np.radians(5.0), n)
    raise StageError(
        f"alignment: gyrocompassing would give {np.degrees(sigma_gc):.1f} deg (1 sigma, more "
        f"than {np.degrees(max_yaw_sigma):.1f}) and no heading or position source was given"
    )
