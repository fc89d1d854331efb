"""session.toml ``[platforms.<ID>]`` and ``[platforms.<ID>.imu]``: read, checked, written.

The platform tables (role, drift_sigma of eq. 7, anchor position) and their raw-sensor keys
(DATA.md "Raw sensors": wheelbase, lever arms, IMU mounting, NHC, IMU noise figures or a
named grade), with the plausible ranges that catch a value given in the wrong unit; read
into :class:`~coopproc.model.Platform` (no stage uses the raw-sensor keys yet) and written
back as session.toml values. The rest of the file is :mod:`coopproc.io.session_toml`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from coopproc.configtools import check_keys, from_table, nearest
from coopproc.errors import ConfigError
from coopproc.io._common import ID_PATTERN
from coopproc.model import ImuNoise, Platform

__all__ = ["IMU_GRADES", "ImuTable", "PlatformTable", "parse_platforms", "platform_entry"]


#: Named IMU grades that may stand for the ``[platforms.ID.imu]`` noise figures.
IMU_GRADES: tuple[str, ...] = ("consumer", "industrial", "tactical", "navigation")


@dataclass(frozen=True)
class ImuTable:
    """The ``[platforms.<ID>.imu]`` table: IMU noise figures, or a named grade."""

    grade: str | None = field(
        default=None,
        metadata={"help": "named grade standing for the figures: " + " | ".join(IMU_GRADES)},
    )
    gyro_noise: float | None = field(
        default=None, metadata={"help": "angle random walk, deg/sqrt(s)"}
    )
    accel_noise: float | None = field(
        default=None, metadata={"help": "velocity random walk, (m/s)/sqrt(s)"}
    )
    gyro_bias: float | None = field(default=None, metadata={"help": "gyro bias instability, deg/h"})
    accel_bias: float | None = field(
        default=None, metadata={"help": "accelerometer bias instability, mg"}
    )
    correlation_time: float | None = field(
        default=None, metadata={"help": "bias correlation time (first-order Gauss-Markov), s"}
    )


@dataclass(frozen=True)
class PlatformTable:
    """A ``[platforms.<ID>]`` table."""

    role: Literal["follower", "leader", "anchor", "tag"] = field(
        default="follower",
        metadata={"help": "follower | leader | anchor | tag (moves, no navigation of its own)"},
    )
    drift_sigma: float | None = field(
        default=None, metadata={"help": "position drift, m/s 1-sigma (sigma_k of eq. 7)"}
    )
    position: tuple[float, float, float] | None = field(
        default=None, metadata={"help": "anchors only: ENU position, metres"}
    )
    wheelbase: float | None = field(
        default=None, metadata={"help": "m, for v_left/v_right odometry"}
    )
    uwb_lever_arm: tuple[float, float, float] | None = field(
        default=None, metadata={"help": "UWB antenna in the body frame (x fwd, y left, z up), m"}
    )
    gnss_lever_arm: tuple[float, float, float] | None = field(
        default=None, metadata={"help": "GNSS antenna in the body frame, m"}
    )
    imu_mounting: tuple[float, float, float] | None = field(
        default=None, metadata={"help": "IMU-to-body roll, pitch, yaw, degrees"}
    )
    nhc: bool | None = field(
        default=None, metadata={"help": "land vehicle: non-holonomic constraints apply"}
    )
    imu: ImuTable | None = field(
        default=None, metadata={"help": "[platforms.<ID>.imu] table: IMU noise figures"}
    )
    max_speed: float | None = field(
        default=None,
        metadata={"help": "plausible speed of its navigation, m/s (absent: the role's default)"},
    )
    max_accel: float | None = field(
        default=None,
        metadata={"help": "plausible acceleration, m/s^2 (absent: the role's default)"},
    )
    max_jump: float | None = field(
        default=None,
        metadata={
            "help": "position noise allowed per epoch on top of max_speed, m (absent: role's)"
        },
    )
    height: float | None = field(
        default=None,
        metadata={
            "help": "UWB antenna height (m, up) of a platform moving in a plane: anchor "
            "fixes are solved at it (absent: navigation height, else estimated)"
        },
    )
    planar: bool | None = field(
        default=None,
        metadata={
            "help": "true: moves in a plane (anchor fixes at one height); false: 3-D "
            "fixes (absent: [fusion.lsq] dims)"
        },
    )


# Plausible ranges that catch a value given in the wrong unit: (low, high, unit text).
_LEVER_ARM_MAX_M = 10.0
_IMU_LIMITS: dict[str, tuple[float, float, str]] = {
    "gyro_noise": (0.0, 1.0, "deg/sqrt(s)"),
    "accel_noise": (0.0, 1.0, "(m/s)/sqrt(s)"),
    "gyro_bias": (0.0, 36000.0, "deg/h"),
    "accel_bias": (0.0, 1000.0, "mg"),
    "correlation_time": (0.0, 1e6, "s"),
}


def parse_platforms(table: Any, where: str) -> dict[str, Platform]:
    """The ``[platforms]`` table of session.toml, checked, as platforms by id."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where} [platforms]: expected tables [platforms.<ID>]")
    out = {}
    for pid, sub in table.items():
        if not ID_PATTERN.match(pid):
            raise ConfigError(
                f"{where} [platforms.{pid}]: not a platform id; expected letters, digits, _ and -"
            )
        at = f"{where} [platforms.{pid}]"
        if isinstance(sub, Mapping) and isinstance(sub.get("imu"), Mapping):
            names = [f.name for f in dataclasses.fields(ImuTable)]
            check_keys(sub["imu"], names, f"{where} [platforms.{pid}.imu]")
        p: PlatformTable = from_table(PlatformTable, sub, at)
        if p.drift_sigma is not None and not p.drift_sigma > 0:
            raise ConfigError(f"{at} drift_sigma: {p.drift_sigma}; expected > 0 m/s")
        if p.position is not None and p.role != "anchor":
            raise ConfigError(
                f'{at} position: given for a {p.role}; expected only for role = "anchor"'
            )
        if p.wheelbase is not None and not 0 < p.wheelbase <= _LEVER_ARM_MAX_M:
            raise ConfigError(
                f"{at} wheelbase: {p.wheelbase}; expected metres, 0 < wheelbase <= 10"
            )
        for key in ("uwb_lever_arm", "gnss_lever_arm"):
            arm = getattr(p, key)
            if arm is not None and not all(abs(v) <= _LEVER_ARM_MAX_M for v in arm):
                raise ConfigError(
                    f"{at} {key}: {list(arm)}; expected [x, y, z] in metres, each within +-10"
                )
        if p.imu_mounting is not None and not all(abs(v) <= 360 for v in p.imu_mounting):
            raise ConfigError(
                f"{at} imu_mounting: {list(p.imu_mounting)}; "
                "expected [roll, pitch, yaw] in degrees, each within +-360"
            )
        if p.height is not None and (p.role == "anchor" or p.planar is False):
            raise ConfigError(f"{at} height: given for a {_what(p)}; expected a moving platform")
        if p.height is not None and not abs(p.height) < 1e4:
            raise ConfigError(f"{at} height: {p.height}; expected metres (up), within +-1e4")
        for key in ("max_speed", "max_accel", "max_jump"):
            value = getattr(p, key)
            if value is not None and not 0 < value < 1e6:
                raise ConfigError(f"{at} {key}: {value}; expected a positive bound below 1e6")
        out[pid] = Platform(
            pid,
            p.role,
            p.drift_sigma,
            p.position,
            wheelbase_m=p.wheelbase,
            uwb_lever_arm_m=p.uwb_lever_arm,
            gnss_lever_arm_m=p.gnss_lever_arm,
            imu_mounting_deg=p.imu_mounting,
            nhc=p.nhc,
            imu=None if p.imu is None else _imu(p.imu, f"{where} [platforms.{pid}.imu]"),
            max_motion=(p.max_speed, p.max_accel, p.max_jump),
            antenna=(p.height, p.planar),
        )
    return out


def _what(p: PlatformTable) -> str:
    return "platform with planar = false" if p.role != "anchor" else "anchor (use position)"


def _imu(table: ImuTable, where: str) -> ImuNoise:
    """Check the IMU figures (units by plausible range) into an ImuNoise."""
    if table.grade is not None and table.grade not in IMU_GRADES:
        raise ConfigError(
            f"{where} grade: {table.grade!r}{nearest(table.grade, IMU_GRADES)}; "
            f"expected one of {' | '.join(IMU_GRADES)}"
        )
    for key, (low, high, unit) in _IMU_LIMITS.items():
        value = getattr(table, key)
        if value is not None and not low < value <= high:
            raise ConfigError(f"{where} {key}: {value}; expected {unit}, > {low:g} and <= {high:g}")
    return ImuNoise(
        grade=table.grade,
        gyro_noise_deg_rts=table.gyro_noise,
        accel_noise_mps_rts=table.accel_noise,
        gyro_bias_deg_h=table.gyro_bias,
        accel_bias_mg=table.accel_bias,
        correlation_time_s=table.correlation_time,
    )


def platform_entry(p: Platform) -> dict[str, Any]:
    """A platform's ``[platforms.<ID>]`` table (only the keys that are given)."""
    entry: dict[str, Any] = {"role": p.role}
    if p.drift_sigma_mps is not None:
        entry["drift_sigma"] = p.drift_sigma_mps
    if p.position_enu_m is not None:
        entry["position"] = [float(v) for v in p.position_enu_m]
    entry.update(_sensor_entry(p))
    return entry


def _sensor_entry(p: Platform) -> dict[str, Any]:
    """The raw-sensor keys of a platform that are given, as session.toml values."""
    entry: dict[str, Any] = {}
    if p.wheelbase_m is not None:
        entry["wheelbase"] = p.wheelbase_m
    for key, arm in (
        ("uwb_lever_arm", p.uwb_lever_arm_m),
        ("gnss_lever_arm", p.gnss_lever_arm_m),
        ("imu_mounting", p.imu_mounting_deg),
    ):
        if arm is not None:
            entry[key] = [float(v) for v in arm]
    if p.nhc is not None:
        entry["nhc"] = p.nhc
    for key, bound in zip(("max_speed", "max_accel", "max_jump"), p.max_motion, strict=True):
        if bound is not None:
            entry[key] = bound
    for key, value in zip(("height", "planar"), p.antenna, strict=True):
        if value is not None:
            entry[key] = value
    if p.imu is not None:
        imu = {
            "grade": p.imu.grade,
            "gyro_noise": p.imu.gyro_noise_deg_rts,
            "accel_noise": p.imu.accel_noise_mps_rts,
            "gyro_bias": p.imu.gyro_bias_deg_h,
            "accel_bias": p.imu.accel_bias_mg,
            "correlation_time": p.imu.correlation_time_s,
        }
        entry["imu"] = {k: v for k, v in imu.items() if v is not None}
    return entry
