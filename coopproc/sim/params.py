"""The simulator's parameters: one frozen dataclass, every figure with its default and help.

A scenario is a set of defaults for :class:`SimParams`; a caller overrides single fields
by name (``simulate(..., uwb_noise_m=0.05)``, ``coopproc simulate --set uwb_noise_m=0.05``).
Unknown names are a :class:`~coopproc.errors.ConfigError` naming the nearest valid one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from coopproc.configtools import from_table, nearest
from coopproc.errors import ConfigError

__all__ = ["NlosSpec", "OutageSpec", "SimParams", "apply_overrides"]


@dataclass(frozen=True)
class NlosSpec:
    """One NLOS event: every range of ``pair`` in [start_s, end_s] gets N(mean_m, sigma^2)."""

    pair: str = field(default="", metadata={"help": "pair name, e.g. 'A-B'"})
    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})
    mean_m: float = field(default=0.5, metadata={"help": "mean of the added NLOS error, m"})


@dataclass(frozen=True)
class OutageSpec:
    """A UWB outage: no range of any pair in [start_s, end_s] (paper 003 section 3.4)."""

    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})


def _f(default: Any, help_text: str) -> Any:
    return field(default=default, metadata={"help": help_text})


@dataclass(frozen=True)
class SimParams:
    """Every physical figure of a simulated session (defaults: paper 000 section 4)."""

    # session and time base
    duration_s: float = _f(600.0, "session length, s")
    platforms: int = _f(3, "number of platforms (anchors included)")
    gps_week: int = _f(2178, "GPS week of the session")
    start_tow_s: float = _f(108000.0, "GPS seconds of week of the first epoch")
    origin_llh: tuple[float, float, float] = _f(
        (34.7980, 113.6590, 110.0), "ENU origin: latitude deg, longitude deg, height m"
    )
    nav_rate_hz: float = _f(10.0, "navigation (INS/OD, GNSS/INS) output rate, Hz")
    range_rate_hz: float = _f(1.0, "UWB ranging rate per pair, Hz")
    ref_rate_hz: float = _f(5.0, "GNSS-PPK reference rate, Hz")
    # motion
    speed_mps: float = _f(0.5, "formation (or target) speed, m/s")
    distance_rate_mps: float = _f(
        0.1, "RMS rate of change of the true inter-platform distances (non-rigid formation)"
    )
    height_amplitude_m: float = _f(0.3, "amplitude of the terrain height changes, m")
    # dead reckoning (followers): INS/odometer
    gyro_bias_dph: float = _f(
        2.7, "gyro bias bound, deg/h; each follower draws |b| in [0.5, 1] x this, random sign"
    )
    gyro_arw_dpsh: float = _f(0.15, "gyro angle random walk, deg/sqrt(h)")
    heading_init_sigma_deg: float = _f(0.05, "initial heading error, 1-sigma, deg")
    odo_scale_sigma: float = _f(0.003, "odometer scale-factor error, 1-sigma (0.003 = 0.3 %)")
    odo_noise_m: float = _f(0.005, "odometer distance noise, m per sqrt(m) travelled")
    init_error_m: float = _f(0.10, "initial horizontal position error per axis, 1-sigma, m")
    height_rw_m: float = _f(0.002, "dead-reckoning height random walk, m per sqrt(s)")
    # leaders: GNSS/INS
    leader_sigma_m: float = _f(0.02, "GNSS/INS horizontal noise per axis, 1-sigma, m")
    leader_sigma_up_m: float = _f(0.03, "GNSS/INS vertical noise, 1-sigma, m")
    leader_corr_s: float = _f(10.0, "correlation time of the GNSS/INS noise (Gauss-Markov), s")
    # UWB
    uwb_noise_m: float = _f(0.08, "true UWB white ranging noise, 1-sigma, m")
    uwb_declared_sigma_m: float = _f(
        0.15, "ranging sigma declared in session.toml and the sigma column (3 sigma = 45 cm)"
    )
    dropout_rate: float = _f(0.02, "probability that one range epoch is missing")
    gross_error_rate: float = _f(0.0, "probability that one range carries a gross error")
    gross_error_m: float = _f(2.0, "gross error magnitude, m (sign random, +-25 % spread)")
    nlos_sigma_m: float = _f(0.1, "1-sigma of the NLOS error around its mean, m (paper 000 4.3)")
    nlos_events: tuple[NlosSpec, ...] = _f((), "NLOS events (pair, start_s, end_s, mean_m)")
    random_nlos_per_pair_hour: float = _f(
        0.0, "extra random NLOS events per pair and hour (10-30 s, means 0.4-0.6 m)"
    )
    outages: tuple[OutageSpec, ...] = _f((), "UWB outages (start_s, end_s): no ranges at all")
    rssi: bool = _f(True, "write an 'rssi' extra column (dBm) in ranges.csv")
    # reference: GNSS-PPK
    ref_sigma_m: float = _f(0.01, "PPK fixed-solution horizontal noise per axis, 1-sigma, m")
    ref_sigma_up_m: float = _f(0.02, "PPK fixed-solution vertical noise, 1-sigma, m")
    float_fraction: float = _f(0.03, "fraction of reference epochs in float (Q = 2) segments")
    float_sigma_m: float = _f(0.08, "PPK float-solution noise per axis, 1-sigma, m")
    # single-auxiliary (paper 004 section 5)
    aux_static: bool = _f(False, "single-auxiliary: the auxiliary A1 stands still")
    second_aux: bool = _f(False, "single-auxiliary: add a second auxiliary A2 with bad ranging")
    aux2_bias_m: float = _f(0.6, "single-auxiliary: A2 peak-shift (bias) of its ranges, m")
    aux2_noise_m: float = _f(0.25, "single-auxiliary: A2 Laplace noise scale of its ranges, m")

    def __post_init__(self) -> None:
        positive = ("duration_s", "nav_rate_hz", "range_rate_hz", "ref_rate_hz")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, found {getattr(self, name)}")
        nonneg = (
            "speed_mps", "distance_rate_mps", "uwb_noise_m", "nlos_sigma_m", "gross_error_m",
            "odo_noise_m", "init_error_m", "leader_sigma_m", "ref_sigma_m",
        )  # fmt: skip
        for name in nonneg:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, found {getattr(self, name)}")
        for name in ("dropout_rate", "gross_error_rate", "float_fraction"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise ValueError(f"{name} must be in [0, 1), found {getattr(self, name)}")
        if self.platforms < 1:
            raise ValueError(f"platforms must be >= 1, found {self.platforms}")
        if self.start_tow_s < 0 or self.start_tow_s + self.duration_s >= 604800.0:
            raise ValueError(
                "start_tow_s + duration_s must stay inside one GPS week (< 604800 s), found "
                f"{self.start_tow_s} + {self.duration_s}"
            )
        for event in self.nlos_events:
            if event.end_s < event.start_s:
                raise ValueError(f"NLOS event on {event.pair} ends before it starts")


def _convert_specs(key: str, value: Any, kind: type) -> tuple[Any, ...]:
    """Events given as spec objects, mappings or plain sequences."""
    if not isinstance(value, list | tuple):
        raise ConfigError(f"simulation parameter {key}: expected a list, found {value!r}")
    out = []
    for item in value:
        if isinstance(item, kind):
            out.append(item)
        elif isinstance(item, Mapping):
            out.append(from_table(kind, item, f"simulation parameter {key}"))
        elif isinstance(item, list | tuple):
            names = [f.name for f in dataclasses.fields(kind)]
            out.append(from_table(kind, dict(zip(names, item, strict=False)), key))
        else:
            raise ConfigError(f"simulation parameter {key}: cannot read {item!r}")
    return tuple(out)


def apply_overrides(base: SimParams, overrides: Mapping[str, Any]) -> SimParams:
    """``base`` with fields replaced by ``overrides`` (converted and checked like TOML)."""
    names = {f.name for f in dataclasses.fields(SimParams)}
    changes: dict[str, Any] = {}
    for key, value in overrides.items():
        if key not in names:
            raise ConfigError(f"unknown simulation parameter '{key}'{nearest(key, names)}")
        if value is None:
            continue
        if key == "nlos_events":
            changes[key] = _convert_specs(key, value, NlosSpec)
        elif key == "outages":
            changes[key] = _convert_specs(key, value, OutageSpec)
        else:
            checked = from_table(SimParams, {key: value}, "simulation parameter")
            changes[key] = getattr(checked, key)
    try:
        return dataclasses.replace(base, **changes)
    except ValueError as err:
        raise ConfigError(f"simulation parameters: {err}") from err
