"""Allan deviation of IMU samples and the noise figures ``[platforms.<ID>.imu]`` takes.

The overlapping Allan deviation (``allantools.oadev``, rate data) of each gyro and
accelerometer axis, at about 10 averaging times per decade from one sample to a tenth of
the record. From each curve (IEEE Std 952 reading of the log-log plot):

- **white noise** (angle / velocity random walk) N: the -1/2-slope part of the curve,
  sigma(tau) = N / sqrt(tau), read at tau = 1 s. The points used are the averaging times
  up to the curve's minimum whose local log-log slope is -1/2 +- 0.15 (else the one
  whose slope is nearest -1/2); N is the geometric mean of sigma(tau) sqrt(tau) over them.
  Gyro: rad/sqrt(s) = rad/s/sqrt(Hz), shown in deg/sqrt(s) (``gyro_noise``) and
  deg/sqrt(h) (x 60); accelerometer: (m/s)/sqrt(s) (``accel_noise``), and (m/s)/sqrt(h).
- **bias instability** B = the curve's minimum / 0.664 (the flicker-floor factor
  sqrt(2 ln 2 / pi)): deg/h (``gyro_bias``), mg (``accel_bias``, 1 g = 9.80665 m/s^2).
  ``tau_min_s`` is where the minimum is; when it is at the longest averaging time the
  curve had not turned up yet (``bias_reached`` 0): B is an upper bound, record longer.

The figures of ``session.toml`` are one value per sensor: the largest axis (a filter
that assumes the noisiest axis for all is conservative). The analysis reads the whole
record, or its longest stretch without a gap when it has gaps (Allan deviation needs
even sampling); the unit must be **at rest** for these to be sensor figures, so the
share of 1-s windows at rest is reported and a record mostly in motion gets a note.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import allantools
import numpy as np
import pandas as pd

from coopproc.model import FloatArray, gap_limit_s

__all__ = [
    "ALLAN_COLUMNS",
    "AxisAllan",
    "ImuAllan",
    "allan_curve",
    "allan_frame",
    "axis_allan",
    "imu_allan",
    "imu_toml",
]

#: sigma_min / B for flicker (bias-instability) noise: sqrt(2 ln 2 / pi).
FLICKER_FACTOR = 0.664
G_MPS2 = 9.80665
_SLOPE_TOLERANCE = 0.15
_PER_DECADE = 10
#: A record is taken as at rest when at least this share of its 1-s windows is.
_AT_REST = 0.9

ALLAN_COLUMNS: tuple[str, ...] = (
    "platform",
    "file",
    "sensor",
    "axis",
    "rate_hz",
    "duration_s",
    "static_fraction",
    "random_walk",
    "random_walk_unit",
    "random_walk_per_hour",
    "random_walk_per_hour_unit",
    "bias_instability",
    "bias_unit",
    "tau_min_s",
    "bias_reached",
)
_UNITS = {
    "gyro": ("deg/sqrt(s)", "deg/sqrt(h)", "deg/h"),
    "accel": ("(m/s)/sqrt(s)", "(m/s)/sqrt(h)", "mg"),
}


@dataclass(frozen=True, eq=False)
class AxisAllan:
    """One axis: its Allan deviation curve and the figures read from it (SI units:
    ``white`` rad/sqrt(s) or (m/s)/sqrt(s), ``minimum`` rad/s or m/s^2)."""

    sensor: str
    axis: str
    tau_s: FloatArray
    adev: FloatArray
    white: float
    minimum: float
    tau_min_s: float
    reached: bool

    @property
    def random_walk(self) -> float:
        """deg/sqrt(s) (gyro) or (m/s)/sqrt(s) (accel)."""
        return math.degrees(self.white) if self.sensor == "gyro" else self.white

    @property
    def bias_instability(self) -> float:
        """deg/h (gyro) or mg (accel)."""
        b = self.minimum / FLICKER_FACTOR
        return math.degrees(b) * 3600.0 if self.sensor == "gyro" else b / G_MPS2 * 1e3


@dataclass(frozen=True, eq=False)
class ImuAllan:
    """Every axis of one IMU record, with the facts of the record analysed."""

    platform: str
    source: str
    rate_hz: float
    duration_s: float
    static_fraction: float
    axes: tuple[AxisAllan, ...]
    notes: tuple[str, ...] = ()

    def worst(self, sensor: str) -> AxisAllan:
        """The axis of ``sensor`` with the largest white noise."""
        return max((a for a in self.axes if a.sensor == sensor), key=lambda a: a.white)

    def worst_bias(self, sensor: str) -> AxisAllan:
        """The axis of ``sensor`` with the largest bias instability."""
        return max((a for a in self.axes if a.sensor == sensor), key=lambda a: a.minimum)


def allan_curve(rate: FloatArray, rate_hz: float) -> tuple[FloatArray, FloatArray]:
    """Overlapping Allan deviation of rate samples at log-spaced averaging times, s."""
    n = rate.size
    longest = max(n // 10, 1)
    m = np.unique(np.round(np.logspace(0, math.log10(longest), _PER_DECADE * 8)))
    m = m[m <= longest]
    taus, adev, _err, _n = allantools.oadev(rate, rate=rate_hz, data_type="freq", taus=m / rate_hz)
    ok = np.isfinite(adev) & (adev > 0)
    return np.asarray(taus[ok], dtype=np.float64), np.asarray(adev[ok], dtype=np.float64)


def _white(tau: FloatArray, adev: FloatArray, last: int) -> float:
    """N from the -1/2-slope points up to index ``last`` (see the module text)."""
    log_t, log_a = np.log(tau), np.log(adev)
    slope = np.gradient(log_a, log_t) if tau.size > 1 else np.array([-0.5])
    head = np.arange(last + 1)
    use = head[np.abs(slope[head] + 0.5) <= _SLOPE_TOLERANCE]
    if not use.size:
        use = head[[int(np.argmin(np.abs(slope[head] + 0.5)))]]
    return float(np.exp(np.mean(log_a[use] + 0.5 * log_t[use])))


def axis_allan(sensor: str, axis: str, rate: FloatArray, rate_hz: float) -> AxisAllan:
    """The curve and figures of one axis of rate samples (rad/s or m/s^2)."""
    tau, adev = allan_curve(rate, rate_hz)
    i = int(np.argmin(adev))
    return AxisAllan(
        sensor=sensor,
        axis=axis,
        tau_s=tau,
        adev=adev,
        white=_white(tau, adev, i),
        minimum=float(adev[i]),
        tau_min_s=float(tau[i]),
        reached=i < tau.size - 1,
    )


def _longest_stretch(time_s: FloatArray) -> slice:
    """The longest run of samples without a gap (:func:`coopproc.model.gap_limit_s`)."""
    cuts = np.flatnonzero(np.diff(time_s) > gap_limit_s(time_s)) + 1
    edges = np.concatenate([[0], cuts, [time_s.size]])
    k = int(np.argmax(np.diff(edges)))
    return slice(int(edges[k]), int(edges[k + 1]))


def imu_allan(
    platform: str,
    source: str,
    time_s: FloatArray,
    gyro_radps: FloatArray,
    accel_mps2: FloatArray,
    static_fraction: float = 1.0,
) -> ImuAllan:
    """Allan deviation of every gyro and accelerometer axis of one IMU record."""
    part = _longest_stretch(time_s)
    t = time_s[part]
    rate_hz = 1.0 / float(np.median(np.diff(t)))
    notes: list[str] = []
    if part.stop - part.start < time_s.size:
        notes.append(
            f"{source}: Allan deviation of the longest stretch without a gap, "
            f"{t[-1] - t[0]:.1f} s of {time_s[-1] - time_s[0]:.1f} s"
        )
    if static_fraction < _AT_REST:
        notes.append(
            f"{source}: at rest in only {100 * static_fraction:.0f} % of the 1-s windows; the "
            "Allan deviation then measures the motion, not the sensor: record the IMU at rest "
            "for its noise figures"
        )
    axes = [
        axis_allan(sensor, axis, data[part, k], rate_hz)
        for sensor, data in (("gyro", gyro_radps), ("accel", accel_mps2))
        for k, axis in enumerate("xyz")
    ]
    return ImuAllan(
        platform, source, rate_hz, float(t[-1] - t[0]), static_fraction, tuple(axes), tuple(notes)
    )


def allan_frame(results: Sequence[ImuAllan]) -> pd.DataFrame:
    """The ``allan.csv`` table (:data:`ALLAN_COLUMNS`), one row per platform, sensor, axis."""
    rows = []
    for res in results:
        for a in res.axes:
            unit, unit_h, bias_unit = _UNITS[a.sensor]
            rows.append(
                {
                    "platform": res.platform,
                    "file": res.source,
                    "sensor": a.sensor,
                    "axis": a.axis,
                    "rate_hz": res.rate_hz,
                    "duration_s": res.duration_s,
                    "static_fraction": res.static_fraction,
                    "random_walk": a.random_walk,
                    "random_walk_unit": unit,
                    "random_walk_per_hour": a.random_walk * 60.0,
                    "random_walk_per_hour_unit": unit_h,
                    "bias_instability": a.bias_instability,
                    "bias_unit": bias_unit,
                    "tau_min_s": a.tau_min_s,
                    "bias_reached": int(a.reached),
                }
            )
    frame = pd.DataFrame(rows, columns=list(ALLAN_COLUMNS))
    frame["bias_reached"] = frame["bias_reached"].astype(np.int64)
    return frame


def _sig(value: float) -> str:
    """Four significant digits, as TOML accepts them."""
    return f"{value:.4g}" if 1e-4 <= abs(value) < 1e5 else f"{value:.4e}"


def imu_toml(res: ImuAllan) -> str:
    """The ``[platforms.<ID>.imu]`` figures of one record, ready to paste into session.toml."""
    gyro, accel = res.worst("gyro"), res.worst("accel")
    gb, ab = res.worst_bias("gyro"), res.worst_bias("accel")

    def bound(a: AxisAllan) -> str:
        return "" if a.reached else " (upper bound: the curve had not turned up; record longer)"

    lines = [
        f"[platforms.{res.platform}.imu]   # Allan deviation of {res.source}, "
        f"{res.duration_s:.0f} s at {res.rate_hz:.0f} Hz; largest axis",
        f"gyro_noise = {_sig(gyro.random_walk)}   # deg/sqrt(s), ARW "
        f"{_sig(gyro.random_walk * 60)} deg/sqrt(h) (gyro {gyro.axis})",
        f"accel_noise = {_sig(accel.random_walk)}   # (m/s)/sqrt(s), VRW (accel {accel.axis})",
        f"gyro_bias = {_sig(gb.bias_instability)}   # deg/h, bias instability at "
        f"{gb.tau_min_s:.3g} s (gyro {gb.axis}){bound(gb)}",
        f"accel_bias = {_sig(ab.bias_instability)}   # mg, bias instability at "
        f"{ab.tau_min_s:.3g} s (accel {ab.axis}){bound(ab)}",
    ]
    return "\n".join(lines) + "\n"
