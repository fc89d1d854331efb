"""Aided synthetic INS runs with a known truth: the exact IMU increments of
:mod:`coopproc.ins.synth` with a grade's biases and white noise added, UWB ranges to
anchors (with a lever arm, optionally withheld in an outage window) and odometer speed.
What the engine's tests and ``benchmarks/ins.py`` run on (not the session simulator,
whose IMU model is :mod:`coopproc.sim`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from coopproc.frames import geodetic2enu
from coopproc.ins.align import Alignment
from coopproc.ins.engine import InsAiding, RangeObs, SpeedObs
from coopproc.ins.mechanize import mechanize
from coopproc.ins.models import ImuFigures
from coopproc.ins.synth import circle_imu, straight_imu
from coopproc.model import FloatArray
from coopproc.sensors import ImuData

__all__ = ["ANCHORS_ENU", "AidedScenario", "aided_scenario"]

#: Four anchors around the start point (session ENU at the start, m).
ANCHORS_ENU = np.array(
    [[-15.0, -5.0, 2.0], [15.0, -5.0, 2.5], [15.0, 25.0, 1.5], [-15.0, 25.0, 3.0]]
)


@dataclass(frozen=True, eq=False)
class AidedScenario:
    """IMU samples with errors, the aiding, and the truth in the session frame whose
    origin ``origin_llh`` (deg, deg, m) is the start point."""

    imu: ImuData
    aiding: InsAiding
    origin_llh: tuple[float, float, float]
    alignment: Alignment
    truth_enu: FloatArray
    truth_vel: FloatArray
    truth_yaw: FloatArray


def aided_scenario(
    kind: Literal["circle", "straight"],
    figures: ImuFigures,
    duration_s: float,
    *,
    seed: int = 0,
    rate_hz: float = 200.0,
    uwb_hz: float = 10.0,
    odo_hz: float = 10.0,
    uwb_sigma_m: float = 0.05,
    odo_sigma_mps: float = 0.02,
    lever_b: tuple[float, float, float] = (0.2, 0.1, 0.8),
    outage: tuple[float, float] | None = None,
    lat_deg: float = 48.0,
    speed_mps: float = 2.0,
) -> AidedScenario:
    """A level ``circle`` (radius 10 m at ``speed_mps``) or ``straight`` drive east,
    starting at the origin with yaw 0; biases drawn from the grade's turn-on sigmas;
    ranges at ``uwb_hz`` to :data:`ANCHORS_ENU` (none inside ``outage`` = (t0, t1)),
    odometer at ``odo_hz`` (0: none). The alignment given is the truth with 0.5 deg roll
    and pitch and 3 deg yaw error."""
    dt = 1.0 / rate_hz
    lat, lon, h = np.radians(lat_deg), np.radians(11.0), 500.0
    if kind == "circle":
        s = circle_imu(lat, lon, h, 10.0, speed_mps / 10.0, duration_s, dt)
    else:
        s = straight_imu(lat, lon, h, speed_mps, duration_s, dt)
    origin = (lat_deg, 11.0, 500.0)
    truth = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel).nav
    llh = np.column_stack([np.degrees(truth[:, 0]), np.degrees(truth[:, 1]), truth[:, 2]])
    enu = geodetic2enu(llh, origin)
    rng = np.random.default_rng(seed)
    bias_g = figures.gyro_bias0_radps * rng.normal(size=3)
    bias_a = figures.accel_bias0_mps2 * rng.normal(size=3)
    gyro = s.dtheta / dt + bias_g + rng.normal(0, figures.arw_rad_rts / np.sqrt(dt), s.dtheta.shape)
    accel = s.dvel / dt + bias_a + rng.normal(0, figures.vrw_mps_rts / np.sqrt(dt), s.dvel.shape)
    imu = ImuData("A", "synthetic", s.time_s, gyro, accel, "rate", 0.0)
    lever = np.array(lever_b)
    step = max(1, round(rate_hz / uwb_hz))
    k = np.arange(step, s.time_s.size, step)
    if outage is not None:
        k = k[(s.time_s[k] < outage[0]) | (s.time_s[k] > outage[1])]
    c, sn = np.cos(s.yaw[k]), np.sin(s.yaw[k])
    ant = enu[k] + np.column_stack([c * lever[0] - sn * lever[1], sn * lever[0] + c * lever[1],
                                    np.full(k.size, lever[2])])  # fmt: skip
    n_a = ANCHORS_ENU.shape[0]
    rho = np.linalg.norm(ant[:, None, :] - ANCHORS_ENU[None, :, :], axis=2)
    rho += rng.normal(0, uwb_sigma_m, rho.shape)
    ranges = RangeObs(
        np.repeat(s.time_s[k], n_a), np.tile(ANCHORS_ENU, (k.size, 1)), rho.reshape(-1),
        np.full(rho.size, uwb_sigma_m), lever,
    )  # fmt: skip
    speed = None
    if odo_hz > 0:
        ko = np.arange(0, s.time_s.size, max(1, round(rate_hz / odo_hz)))
        v = np.hypot(s.vel_enu[ko, 0], s.vel_enu[ko, 1]) + rng.normal(0, odo_sigma_mps, ko.size)
        speed = SpeedObs(s.time_s[ko], v, np.full(ko.size, odo_sigma_mps))
    al = Alignment(np.radians(0.5), np.radians(-0.5), s.yaw[0] + np.radians(3.0), "given",
                   np.radians(1.0), np.radians(5.0), 0)  # fmt: skip
    return AidedScenario(imu, InsAiding(ranges=ranges, speed=speed), origin, al, enu,
                         s.vel_enu, s.yaw)  # fmt: skip
