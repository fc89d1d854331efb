"""The simulator's parameters: one frozen dataclass, every figure with its default and help.

A scenario is a set of defaults for :class:`SimParams`; a caller overrides single fields
by name (``simulate(..., uwb_noise_m=0.05)``, ``coopproc simulate --set uwb_noise_m=0.05``).
Unknown names are a :class:`~coopproc.errors.ConfigError` naming the nearest valid one;
a name set where it can do nothing is one too (:mod:`coopproc.sim.options`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from coopproc.configtools import from_table, nearest
from coopproc.errors import ConfigError
from coopproc.sensors import IMU_GRADE_FIGURES

__all__ = [
    "CanyonSpec",
    "NavGapSpec",
    "NlosSpec",
    "OutageSpec",
    "SimParams",
    "apply_overrides",
    "sparse_table",
]

#: Metadata of the fields added after ``sample_logs/`` was made: ``truth/params.toml``
#: lists them only when they differ from their default, so the files of every scenario
#: made before them stay byte for byte what they were.
_SPARSE = {"sparse": True}


@dataclass(frozen=True)
class NlosSpec:
    """One NLOS event: every range of ``pair`` in [start_s, end_s] gets N(mean(t), sigma^2).

    mean(t) = mean_m, or with ``wander_m`` > 0 a slowly varying mean
    mean_m + wander_m (sin(w1 t + p1) + sin(w2 t + p2)) / 2 (periods 60-200 s, random
    phases): a body or wall whose blocking changes as the platforms move.
    """

    pair: str = field(default="", metadata={"help": "pair name, e.g. 'A-B'"})
    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})
    mean_m: float = field(default=0.5, metadata={"help": "mean of the added NLOS error, m"})
    wander_m: float = field(
        default=0.0,
        metadata={"help": "amplitude of the slow variation of the mean inside the event, m"}
        | _SPARSE,
    )


@dataclass(frozen=True)
class OutageSpec:
    """A UWB outage: no range of any pair in [start_s, end_s] (paper 003 section 3.4)."""

    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})


@dataclass(frozen=True)
class NavGapSpec:
    """A logging gap: ``platform``'s nav file has no row in [start_s, end_s].

    The platform's navigation runs on through the gap (the dead reckoning keeps
    integrating), only its output is missing; an ``end_s`` at or past the session end
    makes the nav file end early while the ranges go on.
    """

    platform: str = field(default="", metadata={"help": "platform id, e.g. 'A'"})
    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})


@dataclass(frozen=True)
class CanyonSpec:
    """An urban-canyon segment: in [start_s, end_s] ``platform``'s receiver (every
    platform's when empty) sees only ``satellites`` satellites: the highest ones above the
    mask at the segment's first epoch, as long as they stay above it."""

    start_s: float = field(default=0.0, metadata={"help": "start, seconds from session start"})
    end_s: float = field(default=0.0, metadata={"help": "end, seconds from session start"})
    satellites: int = field(
        default=3, metadata={"help": "satellites left visible (paper 002: 4, 3, 2, 1)"}
    )
    platform: str = field(default="", metadata={"help": "platform id; empty: every platform"})


def _f(default: Any, help_text: str, *, sparse: bool = False) -> Any:
    return field(default=default, metadata={"help": help_text} | (_SPARSE if sparse else {}))


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
    # dead-reckoning faults (not in the declared figures: session.toml stays optimistic)
    heading_drift_dpm: float = _f(
        0.0,
        "heading-rate fault of the first follower (sorted ids), deg/min, random sign, on top "
        "of the gyro bias",
        sparse=True,
    )
    odo_scale_fault: tuple[float, float] = _f(
        (0.0, 0.0),
        "odometer scale fault: each follower adds |k| drawn in [low, high] (random sign) to "
        "its odo_scale_sigma draw, e.g. [0.01, 0.03] = 1-3 %",
        sparse=True,
    )
    slip_rate_per_hour: float = _f(
        0.0,
        "wheel-slip episodes per follower and hour: 2-6 s in which the odometer over-reads "
        "by 20-50 %",
        sparse=True,
    )
    nav_gaps: tuple[NavGapSpec, ...] = _f(
        (), "nav logging gaps (platform, start_s, end_s): no nav rows in them", sparse=True
    )
    # leaders: GNSS/INS
    leader_sigma_m: float = _f(0.02, "GNSS/INS horizontal noise per axis, 1-sigma, m")
    leader_sigma_up_m: float = _f(0.03, "GNSS/INS vertical noise, 1-sigma, m")
    leader_corr_s: float = _f(10.0, "correlation time of the GNSS/INS noise (Gauss-Markov), s")
    leader_white_m: float = _f(
        0.0,
        "GNSS/INS white noise per axis at the nav rate, 1-sigma, m, on top of the Gauss-Markov",
        sparse=True,
    )
    leader_velocity: bool = _f(
        False, "leaders' nav files carry vel_east/north/up (true velocity + noise)", sparse=True
    )
    leader_vel_sigma_mps: float = _f(
        0.02, "GNSS/INS velocity white noise per axis, 1-sigma, m/s", sparse=True
    )
    # UWB
    uwb_noise_m: float = _f(0.08, "true UWB white ranging noise, 1-sigma, m")
    uwb_declared_sigma_m: float = _f(
        0.15, "ranging sigma declared in session.toml and the sigma column (3 sigma = 45 cm)"
    )
    dropout_rate: float = _f(0.02, "probability that one range epoch is missing")
    gross_error_rate: float = _f(0.0, "probability that one range carries a gross error")
    gross_error_m: float = _f(2.0, "gross error magnitude, m (sign random, +-25 % spread)")
    nlos_sigma_m: float = _f(0.1, "1-sigma of the NLOS error around its mean, m (paper 000 4.3)")
    nlos_events: tuple[NlosSpec, ...] = _f(
        (), "NLOS events (pair, start_s, end_s, mean_m[, wander_m])"
    )
    random_nlos_per_pair_hour: float = _f(
        0.0, "extra random NLOS events per pair and hour (10-30 s, means 0.4-0.6 m)"
    )
    outages: tuple[OutageSpec, ...] = _f((), "UWB outages (start_s, end_s): no ranges at all")
    rssi: bool = _f(True, "write an 'rssi' extra column (dBm) in ranges.csv")
    exact_ranges: bool = _f(
        False,
        "ranges = true distances (no noise, bias, NLOS, gross errors, dropouts, outages, "
        "no millimetre rounding)",
        sparse=True,
    )
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
    aux_distance_m: float = _f(
        60.0,
        "multi-auxiliary: distance of the auxiliaries' loop centres from the target's, m",
        sparse=True,
    )
    aux1_moves_at_s: float = _f(
        0.0,
        "multi-auxiliary: A1 stands still until this time (s from the start), then drives",
        sparse=True,
    )
    aux3_tail_m: float = _f(
        0.15,
        "multi-auxiliary: A3 heavy-tailed ranging, scale of its Student-t (2 dof) noise, m",
        sparse=True,
    )

    # raw sensors (issue 12): off unless imu_rate_hz > 0 (coopproc.sim.imu)
    imu_rate_hz: float = _f(
        0.0,
        "IMU rate, Hz (50-1000): write imu_<ID>.csv and odo_<ID>.csv for every moving "
        "platform; 0 = none",
        sparse=True,
    )
    imu_grade: str = _f(
        "industrial", "IMU error grade: consumer | industrial | tactical | navigation", sparse=True
    )
    imu_earth_rate: bool = _f(
        True, "IMU gyros sense the earth rotation (and the accelerometers Coriolis)", sparse=True
    )
    odo_rate_hz: float = _f(10.0, "odometer rate, Hz (1-1000), with imu_rate_hz", sparse=True)
    imu_body: str = _f(
        "vehicle",
        "how the IMU's body moves: vehicle (x along the course, roll 0: NHC holds, odometer "
        "written) | multirotor (tilted by its thrust, yaw its own: no NHC, no odometer)",
        sparse=True,
    )

    # raw GNSS (issue 13): off unless gnss_obs (coopproc.sim.gnss_obs)
    gnss_obs: bool = _f(
        False,
        "write RINEX GPS L1 observations obs_<ID> of every platform and the navigation file",
        sparse=True,
    )
    gnss_nav: str = _f(
        "",
        "RINEX GPS navigation file whose ephemerides the satellites fly; empty: the shared "
        "GEONET file (../shared/data/gnss/07590920.05n)",
        sparse=True,
    )
    gnss_rinex_version: int = _f(
        3, "RINEX version of the files written: 3 (3.04) or 2 (2.11)", sparse=True
    )
    gnss_rate_hz: float = _f(1.0, "GNSS observation rate, Hz (0.1-20)", sparse=True)
    gnss_mask_deg: float = _f(10.0, "elevation mask, deg", sparse=True)
    gnss_code_sigma_m: float = _f(
        0.5, "pseudorange white noise at C/N0 45 dB-Hz, 1-sigma, m", sparse=True
    )
    gnss_doppler_sigma_hz: float = _f(
        0.1, "Doppler white noise at C/N0 45 dB-Hz, 1-sigma, Hz", sparse=True
    )
    gnss_multipath_m: float = _f(
        0.3, "code multipath at zenith, 1-sigma, m (grows as 1 / sin(elevation))", sparse=True
    )
    gnss_multipath_tau_s: float = _f(
        20.0, "correlation time of the multipath (Gauss-Markov), s", sparse=True
    )
    gnss_tropo_error: float = _f(
        0.05,
        "troposphere: true delay = Saastamoinen x (1 + e), e ~ N(0, this) once per session",
        sparse=True,
    )
    gnss_iono_error: float = _f(
        0.3,
        "ionosphere: true delay = Klobuchar x (1 + e), e ~ N(0, this) per satellite",
        sparse=True,
    )
    canyon: tuple[CanyonSpec, ...] = _f(
        (),
        "urban-canyon segments (start_s, end_s, satellites[, platform]): only that many "
        "satellites seen",
        sparse=True,
    )

    def __post_init__(self) -> None:
        positive = ("duration_s", "nav_rate_hz", "range_rate_hz", "ref_rate_hz")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, found {getattr(self, name)}")
        nonneg = (
            "speed_mps", "distance_rate_mps", "uwb_noise_m", "nlos_sigma_m", "gross_error_m",
            "odo_noise_m", "init_error_m", "leader_sigma_m", "ref_sigma_m",
            "heading_drift_dpm", "slip_rate_per_hour", "leader_white_m", "leader_vel_sigma_mps",
            "aux_distance_m", "aux1_moves_at_s", "aux3_tail_m",
        )  # fmt: skip
        for name in nonneg:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, found {getattr(self, name)}")
        for name in ("dropout_rate", "gross_error_rate", "float_fraction"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise ValueError(f"{name} must be in [0, 1), found {getattr(self, name)}")
        if self.imu_rate_hz != 0 and not 50.0 <= self.imu_rate_hz <= 1000.0:
            raise ValueError(f"imu_rate_hz must be 0 or 50-1000 Hz, found {self.imu_rate_hz}")
        if not 1.0 <= self.odo_rate_hz <= 1000.0:
            raise ValueError(f"odo_rate_hz must be 1-1000 Hz, found {self.odo_rate_hz}")
        if self.imu_grade not in IMU_GRADE_FIGURES:
            grades = " | ".join(IMU_GRADE_FIGURES)
            raise ValueError(f"imu_grade must be one of {grades}, found {self.imu_grade!r}")
        if self.imu_body not in ("vehicle", "multirotor"):
            raise ValueError(f"imu_body must be vehicle | multirotor, found {self.imu_body!r}")
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
            if event.wander_m < 0:
                raise ValueError(f"NLOS event on {event.pair}: wander_m must be >= 0")
        for gap in self.nav_gaps:
            if gap.end_s < gap.start_s:
                raise ValueError(f"nav gap of {gap.platform} ends before it starts")
        for outage in self.outages:
            if outage.end_s < outage.start_s:
                raise ValueError(
                    f"outage at {outage.start_s:g}-{outage.end_s:g} s ends before it starts"
                )
        self._check_gnss()
        low, high = self.odo_scale_fault
        if not 0.0 <= low <= high:
            raise ValueError(
                f"odo_scale_fault must be [low, high] with 0 <= low <= high, found {[low, high]}"
            )

    def _check_gnss(self) -> None:
        if self.gnss_rinex_version not in (2, 3):
            raise ValueError(f"gnss_rinex_version must be 2 or 3, found {self.gnss_rinex_version}")
        if not 0.1 <= self.gnss_rate_hz <= 20.0:
            raise ValueError(f"gnss_rate_hz must be 0.1-20 Hz, found {self.gnss_rate_hz}")
        if not 0.0 <= self.gnss_mask_deg < 90.0:
            raise ValueError(f"gnss_mask_deg must be in [0, 90), found {self.gnss_mask_deg}")
        for name in (
            "gnss_code_sigma_m", "gnss_doppler_sigma_hz", "gnss_multipath_m",
            "gnss_multipath_tau_s", "gnss_tropo_error", "gnss_iono_error",
        ):  # fmt: skip
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, found {getattr(self, name)}")
        for seg in self.canyon:
            if seg.end_s < seg.start_s:
                raise ValueError(f"canyon segment at {seg.start_s:g} s ends before it starts")
            if seg.satellites < 0:
                raise ValueError(
                    f"canyon segment at {seg.start_s:g} s: satellites must be >= 0, "
                    f"found {seg.satellites}"
                )


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


_SPEC_FIELDS: dict[str, type] = {
    "nlos_events": NlosSpec,
    "outages": OutageSpec,
    "nav_gaps": NavGapSpec,
    "canyon": CanyonSpec,
}


def apply_overrides(base: SimParams, overrides: Mapping[str, Any]) -> SimParams:
    """``base`` with fields replaced by ``overrides`` (converted and checked like TOML)."""
    names = {f.name for f in dataclasses.fields(SimParams)}
    changes: dict[str, Any] = {}
    for key, value in overrides.items():
        if key not in names:
            raise ConfigError(f"unknown simulation parameter '{key}'{nearest(key, names)}")
        if value is None:
            continue
        if key in _SPEC_FIELDS:
            changes[key] = _convert_specs(key, value, _SPEC_FIELDS[key])
        else:
            checked = from_table(SimParams, {key: value}, "simulation parameter")
            changes[key] = getattr(checked, key)
    try:
        return dataclasses.replace(base, **changes)
    except ValueError as err:
        raise ConfigError(f"simulation parameters: {err}") from err


def sparse_table(obj: Any) -> Any:
    """``obj`` (SimParams, a spec, a tuple of them) as plain TOML data; the fields marked
    sparse only where they differ from their default."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {
            f.name: sparse_table(getattr(obj, f.name))
            for f in dataclasses.fields(obj)
            if not (f.metadata.get("sparse") and getattr(obj, f.name) == f.default)
        }
    if isinstance(obj, tuple | list):
        return [sparse_table(v) for v in obj]
    return obj
