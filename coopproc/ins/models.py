"""The IMU figures the INS filter uses: resolved from a platform's ``[platforms.X.imu]``
(read and checked by the session reader into :class:`coopproc.model.ImuNoise`) and the
project's named grades (:data:`coopproc.sensors.IMU_GRADE_FIGURES`, documented in
docs/simulator.md), and the continuous noise densities derived from them
(docs/methods-ins.md).

Units as DATA.md: ``gyro_noise`` angle random walk, deg/sqrt(s); ``accel_noise`` velocity
random walk, (m/s)/sqrt(s); ``gyro_bias`` bias instability, deg/h; ``accel_bias`` mg;
``correlation_time`` s (first-order Gauss-Markov); turn-on biases (deg/h, mg) and scale
factors (ppm) from the grade.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from coopproc.model import ImuNoise
from coopproc.sensors import IMU_GRADE_FIGURES

__all__ = ["DEFAULT_GRADE", "GRADES", "PAPER003", "ImuFigures", "imu_figures"]

_DEG = np.pi / 180.0
_MG = 9.80665e-3


@dataclass(frozen=True)
class ImuFigures:
    """Noise figures of one IMU in the units of DATA.md; SI properties derived."""

    gyro_noise: float  # deg/sqrt(s)
    accel_noise: float  # (m/s)/sqrt(s)
    gyro_bias: float  # deg/h, bias instability
    accel_bias: float  # mg, bias instability
    correlation_time: float  # s
    gyro_turn_on: float = 0.0  # deg/h, 1-sigma constant bias of a run
    accel_turn_on: float = 0.0  # mg
    gyro_scale: float = 0.0  # ppm
    accel_scale: float = 0.0  # ppm

    @property
    def arw_rad_rts(self) -> float:
        """Angle random walk, rad/sqrt(s)."""
        return self.gyro_noise * _DEG

    @property
    def vrw_mps_rts(self) -> float:
        """Velocity random walk, (m/s)/sqrt(s)."""
        return self.accel_noise

    @property
    def gyro_bias_radps(self) -> float:
        return self.gyro_bias * _DEG / 3600.0

    @property
    def accel_bias_mps2(self) -> float:
        return self.accel_bias * _MG

    @property
    def gyro_bias0_radps(self) -> float:
        """Initial 1-sigma of the gyro bias: turn-on and instability together."""
        return float(np.hypot(self.gyro_turn_on, self.gyro_bias)) * _DEG / 3600.0

    @property
    def accel_bias0_mps2(self) -> float:
        """Initial 1-sigma of the accelerometer bias: turn-on and instability together."""
        return float(np.hypot(self.accel_turn_on, self.accel_bias)) * _MG

    def bias_psd(self) -> tuple[float, float]:
        """Driving-noise densities (gyro rad^2/s^3, accel m^2/s^5) of the Gauss-Markov biases,
        q = 2 sigma^2 / tau, so that the steady-state sigma is the bias instability."""
        tau = self.correlation_time
        return 2.0 * self.gyro_bias_radps**2 / tau, 2.0 * self.accel_bias_mps2**2 / tau


#: The project's named grades (coopproc.sensors, the simulator's figures) as ImuFigures.
GRADES: dict[str, ImuFigures] = {
    name: ImuFigures(
        g.gyro_arw,
        g.accel_vrw,
        g.gyro_bias,
        g.accel_bias,
        g.correlation_time_s,
        g.gyro_turn_on,
        g.accel_turn_on,
        g.scale_ppm,
        g.scale_ppm,
    )
    for name, g in IMU_GRADE_FIGURES.items()
}
DEFAULT_GRADE = "industrial"
#: The IMU of paper 003 section 3.1 (0.03 deg/sqrt(h), 0.05 m/s/sqrt(h), 0.5 deg/h,
#: 250 mGal = 0.25 mg), for reproducing its Table 1.
PAPER003 = ImuFigures(0.03 / 60.0, 0.05 / 60.0, 0.5, 0.25, 3600.0)


def imu_figures(noise: ImuNoise | None, default_grade: str = DEFAULT_GRADE) -> ImuFigures:
    """The figures of a platform: its grade (or ``default_grade``), with the figures the
    session gives overriding the grade's. The session reader has checked the values."""
    if noise is None:
        return GRADES[default_grade]
    base = GRADES[noise.grade or default_grade]
    given = {
        "gyro_noise": noise.gyro_noise_deg_rts,
        "accel_noise": noise.accel_noise_mps_rts,
        "gyro_bias": noise.gyro_bias_deg_h,
        "accel_bias": noise.accel_bias_mg,
        "correlation_time": noise.correlation_time_s,
    }
    return replace(base, **{k: float(v) for k, v in given.items() if v is not None})
