"""The raw-sensor samples of a platform (DATA.md "Raw sensors"), shared by every layer.

:class:`ImuData` (``imu_<ID>.csv``, ``sensor_msgs/msg/Imu``) and :class:`OdometerData`
(``odo_<ID>.csv``, ``nav_msgs/msg/Odometry`` twist): what the readers of
:mod:`coopproc.io.imu_csv` / :mod:`coopproc.io.odo_csv` and the bag reader return, what
the simulator writes, and what the INS stages read from ``coopproc.model.Session``
(which imports this module).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from coopproc.sampling import FloatArray, gap_limit_s

__all__ = ["IMU_GRADE_FIGURES", "ImuData", "ImuGrade", "OdometerData"]


class _Sampled:
    """The timing of a sensor's samples (``time_s``, strictly increasing)."""

    time_s: FloatArray

    @property
    def interval_s(self) -> float:
        """The nominal sample interval (median), s."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def rate_hz(self) -> float:
        """The nominal sample rate, Hz."""
        return 1.0 / self.interval_s

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])


@dataclass(frozen=True, eq=False)
class ImuData(_Sampled):
    """IMU samples of one file, in rates, in the body frame (x forward, y left, z up).

    ``time_s`` strictly increasing (session time base); ``gyro_radps`` and ``accel_mps2``
    (n, 3); ``form`` says what the file held (``rate`` or ``increment``);
    ``static_fraction`` the share of 1-s windows in which the accelerometers say the unit
    is at rest.
    """

    platform: str
    source: str
    time_s: FloatArray
    gyro_radps: FloatArray
    accel_mps2: FloatArray
    form: Literal["rate", "increment"]
    static_fraction: float
    notes: tuple[str, ...] = ()

    def gaps(self) -> int:
        """How many intervals are gaps (longer than 2.5 x the median, the gap rule of
        :func:`coopproc.model.gap_limit_s`)."""
        return int(np.count_nonzero(np.diff(self.time_s) > gap_limit_s(self.time_s)))


@dataclass(frozen=True, eq=False)
class OdometerData(_Sampled):
    """Odometer samples of one platform (body x forward, z up).

    ``speed_mps`` forward speed; ``yaw_rate_radps`` the yaw rate (counter-clockwise
    positive) of wheel speeds or of a ``nav_msgs/msg/Odometry`` twist (``angular.z``),
    else None; ``form`` what the source held (``speed``, ``wheels``, ``twist``).
    """

    platform: str
    source: str
    time_s: FloatArray
    speed_mps: FloatArray
    form: Literal["speed", "wheels", "twist"]
    yaw_rate_radps: FloatArray | None = None
    wheelbase_m: float | None = None
    notes: tuple[str, ...] = field(default=())

    def distance_m(self) -> float:
        """Distance travelled (trapezoid of |speed|), m."""
        s = np.abs(self.speed_mps)
        return float(np.sum(0.5 * (s[1:] + s[:-1]) * np.diff(self.time_s)))

    def gaps(self) -> int:
        """How many intervals are gaps (longer than 2.5 x the median)."""
        return int(np.count_nonzero(np.diff(self.time_s) > gap_limit_s(self.time_s)))


@dataclass(frozen=True)
class ImuGrade:
    """The error figures of a named IMU grade (session.toml ``[platforms.ID.imu] grade``,
    the simulator's ``imu_grade``); typical datasheet values of each class (docs/simulator.md).

    White noise: ``gyro_arw`` deg/sqrt(s), ``accel_vrw`` (m/s)/sqrt(s); bias instability
    (first-order Gauss-Markov, steady-state 1-sigma, ``correlation_time_s``): ``gyro_bias``
    deg/h, ``accel_bias`` mg; constant turn-on bias, 1-sigma: ``gyro_turn_on`` deg/h,
    ``accel_turn_on`` mg; scale-factor error, 1-sigma: ``scale_ppm``.
    """

    name: str
    gyro_arw: float
    accel_vrw: float
    gyro_bias: float
    accel_bias: float
    correlation_time_s: float
    gyro_turn_on: float
    accel_turn_on: float
    scale_ppm: float


#: The named grades (the names of :data:`coopproc.io.session_platforms.IMU_GRADES`).
IMU_GRADE_FIGURES: dict[str, ImuGrade] = {
    g.name: g
    for g in (
        # phone / hobby MEMS (e.g. MPU-6050 / BMI160 class)
        ImuGrade("consumer", 0.01, 0.003, 30.0, 1.0, 300.0, 720.0, 30.0, 5000.0),
        # industrial MEMS (e.g. ADIS1646x / Xsens MTi class)
        ImuGrade("industrial", 0.0035, 0.0006, 10.0, 0.2, 1000.0, 200.0, 5.0, 1000.0),
        # tactical (e.g. STIM300 / HG1700 class)
        ImuGrade("tactical", 0.002, 0.0003, 1.0, 0.05, 3600.0, 10.0, 1.0, 300.0),
        # navigation (ring-laser / fibre-optic, servo accelerometers)
        ImuGrade("navigation", 0.00005, 0.00002, 0.01, 0.01, 3600.0, 0.01, 0.025, 50.0),
    )
}
