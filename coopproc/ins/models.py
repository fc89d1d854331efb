"""IMU noise figures and named grades (DATA.md ``[platforms.X.imu]``), and the continuous
noise densities of the error-state model derived from them (docs/methods-ins.md).

Config keys and units (DATA.md): ``gyro_noise`` angle random walk, deg/sqrt(s);
``accel_noise`` velocity random walk, (m/s)/sqrt(s); ``gyro_bias`` bias instability,
deg/h; ``accel_bias`` mg; ``correlation_time`` s (first-order Gauss-Markov); optional
``gyro_scale``/``accel_scale`` ppm; ``grade`` names a set of them (keys given beside it
override the grade's values).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import numpy as np

from coopproc.configtools import check_keys, nearest
from coopproc.errors import ConfigError

__all__ = ["GRADES", "ImuNoise", "imu_noise_from_table"]

_DEG = np.pi / 180.0
_MG = 9.80665e-3


@dataclass(frozen=True)
class ImuNoise:
    """Noise figures of one IMU in the units of DATA.md; SI properties derived."""

    gyro_noise: float  # deg/sqrt(s)
    accel_noise: float  # (m/s)/sqrt(s)
    gyro_bias: float  # deg/h
    accel_bias: float  # mg
    correlation_time: float  # s
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

    def bias_psd(self) -> tuple[float, float]:
        """Driving-noise densities (gyro rad^2/s^3, accel m^2/s^5) of the Gauss-Markov biases,
        q = 2 sigma^2 / tau, so that the steady-state sigma is the bias instability."""
        tau = self.correlation_time
        return 2.0 * self.gyro_bias_radps**2 / tau, 2.0 * self.accel_bias_mps2**2 / tau


#: Named grades. consumer-mems: smartphone/low-cost MEMS (BMI/ICM class) datasheets;
#: industrial-mems: the DATA.md example (ADIS class); tactical: paper 002 Table 1 for the
#: gyro (0.125 deg/sqrt(h), 1 deg/h, 1 mg) with paper 003's velocity random walk
#: (0.05 m/s/sqrt(h)); paper003: the IMU of paper 003 section 3.1 (0.03 deg/sqrt(h),
#: 0.05 m/s/sqrt(h), 0.5 deg/h, 250 mGal).
GRADES: dict[str, ImuNoise] = {
    "consumer-mems": ImuNoise(0.01, 0.002, 30.0, 2.0, 300.0, 5000.0, 5000.0),
    "industrial-mems": ImuNoise(0.0035, 0.0006, 10.0, 0.5, 3600.0, 1000.0, 1000.0),
    "tactical": ImuNoise(0.125 / 60.0, 0.05 / 60.0, 1.0, 1.0, 3600.0, 150.0, 300.0),
    "paper003": ImuNoise(0.03 / 60.0, 0.05 / 60.0, 0.5, 0.25, 3600.0, 0.0, 0.0),
}


def imu_noise_from_table(table: Mapping[str, object], where: str) -> ImuNoise:
    """The noise of a ``[platforms.X.imu]`` table: ``grade`` (default industrial-mems)
    with the given keys overriding; ConfigError naming ``where`` and the key otherwise."""
    keys = {f.name for f in fields(ImuNoise)}
    check_keys(table, keys | {"grade"}, where)
    grade = str(table.get("grade", "industrial-mems"))
    if grade not in GRADES:
        raise ConfigError(f"{where}: unknown IMU grade '{grade}'{nearest(grade, GRADES)}")
    values: dict[str, float] = {}
    for key in keys & set(table):
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{where}: {key} = {value!r} is not a number")
        if not value > 0 and not (key.endswith("scale") and value == 0):
            raise ConfigError(f"{where}: {key} = {value!r} must be positive")
        values[key] = float(value)
    return replace(GRADES[grade], **values)
