"""Typed containers passed between coopproc's layers.

Everything here is in ONE time base (the session's, seconds) and ONE local level frame
(ENU, metres, at the session origin): readers normalize, stages never convert.
Containers are frozen; stages return new objects and never mutate their inputs.

Output tables (``Result``) are pandas DataFrames whose columns are fixed by the data
contract (``shared/design/DATA.md``, mirrored in ``docs/formats.md``); the column tuples
(:mod:`coopproc.names`, re-exported here) are the single source of those names; the
array type and the gap rule come from :mod:`coopproc.sampling` (re-exported too).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.names import (
    DI_COLUMNS,
    DR_STATES_COLUMNS,
    METHODS,
    METRICS_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    POSITION_METRICS_COLUMNS,
    POSITIONS_COLUMNS,
    RANGE_COLUMNS,
    RANGES_OUT_COLUMNS,
    STATES_COLUMNS,
    pair_members,
    pair_name,
)
from coopproc.sampling import GAP_FACTOR, FloatArray, gap_limit_s
from coopproc.sensors import ImuData, OdometerData

__all__ = [
    "DI_COLUMNS",
    "DR_STATES_COLUMNS",
    "GAP_FACTOR",
    "METHODS",
    "METRICS_COLUMNS",
    "NLOS_ESTIMATE_COLUMNS",
    "NLOS_EVENT_COLUMNS",
    "POSITIONS_COLUMNS",
    "POSITION_METRICS_COLUMNS",
    "RANGES_OUT_COLUMNS",
    "RANGE_COLUMNS",
    "ROLES",
    "STATES_COLUMNS",
    "FloatArray",
    "ImuNoise",
    "Platform",
    "RangeTable",
    "Result",
    "SensorFile",
    "Session",
    "SessionConfig",
    "Trajectory",
    "gap_limit_s",
    "pair_members",
    "pair_name",
]

Role = Literal["follower", "leader", "anchor", "tag"]
#: ``tag``: moves, has no navigation solution of its own (DATA.md "Raw sensors").
ROLES: tuple[str, ...] = ("follower", "leader", "anchor", "tag")
TimeBase = Literal["gps_tow", "unix", "relative"]


@dataclass(frozen=True)
class ImuNoise:
    """IMU noise figures of a platform (``[platforms.ID.imu]``); None: not given."""

    #: Named grade standing for the figures (``consumer``, ``industrial``, ...).
    grade: str | None = None
    #: Angle random walk, deg/sqrt(s).
    gyro_noise_deg_rts: float | None = None
    #: Velocity random walk, (m/s)/sqrt(s).
    accel_noise_mps_rts: float | None = None
    #: Gyro bias instability, deg/h.
    gyro_bias_deg_h: float | None = None
    #: Accelerometer bias instability, mg.
    accel_bias_mg: float | None = None
    #: First-order Gauss-Markov correlation time of the biases, s.
    correlation_time_s: float | None = None


@dataclass(frozen=True)
class Platform:
    """One moving body (or a fixed anchor) with its own navigation and a UWB unit."""

    id: str
    role: Role = "follower"
    #: Position drift, metres per second, 1-sigma (sigma_k of paper 000 eq. (7)); None: default.
    drift_sigma_mps: float | None = None
    position_enu_m: tuple[float, float, float] | None = None  #: anchors only: ENU position, m
    # Raw-sensor figures (DATA.md "Raw sensors"); read and checked, not used by the stages yet.
    #: Wheelbase of v_left/v_right odometry, metres.
    wheelbase_m: float | None = None
    #: UWB antenna in the body frame (x forward, y left, z up), metres.
    uwb_lever_arm_m: tuple[float, float, float] | None = None
    #: GNSS antenna in the body frame, metres.
    gnss_lever_arm_m: tuple[float, float, float] | None = None
    #: IMU-to-body roll, pitch, yaw, degrees.
    imu_mounting_deg: tuple[float, float, float] | None = None
    nhc: bool | None = None  #: land vehicle: non-holonomic constraints apply; None: not given
    #: IMU noise figures; None: not given.
    imu: ImuNoise | None = None
    max_motion: tuple[float | None, ...] = (None, None, None)  #: speed, accel, jump: plausible.py
    antenna: tuple[float | None, bool | None] = (None, None)  #: height m, planar: anchor_lsq.py


@dataclass(frozen=True)
class SensorFile:
    """A raw-sensor file of a session directory (DATA.md "Raw sensors").

    ``kind``: ``imu`` (imu_<ID>.csv), ``odo`` (odo_<ID>.csv), ``gnss_obs`` (RINEX
    observations obs_<ID>.<yy>o / .rnx) or ``gnss_nav`` (broadcast ephemerides, no
    platform).
    """

    kind: Literal["imu", "odo", "gnss_obs", "gnss_nav"]
    path: Path
    platform: str | None = None


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Time-indexed positions of one platform in the session frame.

    ``time_s`` is strictly increasing; ``enu_m`` is (n, 3) east, north, up in metres.
    Optional per-epoch arrays have the same length; ``sigma_enu_m`` is (n, 3) 1-sigma.
    """

    platform: str
    time_s: FloatArray
    enu_m: FloatArray
    sigma_enu_m: FloatArray | None = None
    vel_enu_mps: FloatArray | None = None
    heading_deg: FloatArray | None = None
    #: Solution quality per epoch where the source has one (RTKLIB Q: 1 fix, 2 float, ...).
    quality: NDArray[np.int64] | None = None
    #: The file (or MCAP channel) it was read from, for messages.
    source: str = ""

    def __len__(self) -> int:
        return int(self.time_s.shape[0])

    @property
    def span_s(self) -> tuple[float, float]:
        """First and last time."""
        return float(self.time_s[0]), float(self.time_s[-1])

    def interpolate(self, time_s: FloatArray) -> FloatArray:
        """Positions (m, 3) linearly interpolated at ``time_s``; NaN outside the span."""
        t = np.asarray(time_s, dtype=np.float64)
        out = np.empty((t.shape[0], 3), dtype=np.float64)
        for axis in range(3):
            out[:, axis] = np.interp(t, self.time_s, self.enu_m[:, axis])
        outside = (t < self.time_s[0]) | (t > self.time_s[-1])
        out[outside] = np.nan
        return out

    def interpolate_within(self, time_s: FloatArray, max_gap_s: float | None = None) -> FloatArray:
        """Like :meth:`interpolate`, but NaN inside gaps too: nothing is invented across them.

        A gap is an interval between two consecutive epochs longer than ``max_gap_s``
        (default: :meth:`gap_limit_s`, 2.5 times the median interval), e.g. reference
        epochs dropped by the RTKLIB Q filter or an outage; a platform turning inside it
        would make a straight line a wrong position. Times that fall exactly on an epoch are kept.
        """
        t = np.asarray(time_s, dtype=np.float64)
        out = self.interpolate(t)
        if len(self) < 2:
            return out
        steps = np.diff(self.time_s)
        limit = self.gap_limit_s() if max_gap_s is None else max_gap_s
        right = np.searchsorted(self.time_s, t)
        idx = np.clip(right, 1, len(self) - 1)
        exact = self.time_s[np.minimum(right, len(self) - 1)] == t
        out[(steps[idx - 1] > limit) & ~exact] = np.nan
        return out

    def covered(self, time_s: FloatArray) -> NDArray[np.bool_]:
        """Where :meth:`interpolate_within` gives a position (its east not NaN): inside the
        span and not inside a gap, or exactly on an epoch; the same mask without
        interpolating (with finite positions; else from the interpolation)."""
        t = np.asarray(time_s, dtype=np.float64)
        if len(self) < 2 or not self._finite:
            return ~np.isnan(self.interpolate_within(t)[:, 0])
        inside = (t >= self.time_s[0]) & (t <= self.time_s[-1])
        right = np.searchsorted(self.time_s, t)
        idx = np.clip(right, 1, len(self) - 1)
        exact = self.time_s[np.minimum(right, len(self) - 1)] == t
        gap = (self.time_s[idx] - self.time_s[idx - 1] > self.gap_limit_s()) & ~exact
        return inside & ~gap

    @functools.cached_property
    def _finite(self) -> bool:
        return bool(np.isfinite(self.enu_m).all())

    def gap_limit_s(self) -> float:
        """The longest interval between epochs that is not a gap (:func:`gap_limit_s`), s."""
        return self._gap_limit

    @functools.cached_property
    def _gap_limit(self) -> float:  # a median over every epoch: once per trajectory
        return gap_limit_s(self.time_s)

    def gaps_s(self) -> FloatArray:
        """(k, 2) start and end times of every gap (intervals longer than the limit)."""
        steps = np.diff(self.time_s)
        at = np.flatnonzero(steps > self.gap_limit_s())
        return np.column_stack([self.time_s[at], self.time_s[at + 1]]).astype(np.float64)

    def frame(self) -> pd.DataFrame:
        """The trajectory as a DataFrame with the nav CSV column names."""
        data: dict[str, FloatArray | NDArray[np.int64]] = {
            "time": self.time_s,
            "east": self.enu_m[:, 0],
            "north": self.enu_m[:, 1],
            "up": self.enu_m[:, 2],
        }
        if self.sigma_enu_m is not None:
            for i, axis in enumerate(("east", "north", "up")):
                data[f"sigma_{axis}"] = self.sigma_enu_m[:, i]
        if self.vel_enu_mps is not None:
            for i, axis in enumerate(("east", "north", "up")):
                data[f"vel_{axis}"] = self.vel_enu_mps[:, i]
        if self.heading_deg is not None:
            data["heading"] = self.heading_deg
        if self.quality is not None:
            data["quality"] = self.quality
        return pd.DataFrame(data)


@dataclass(frozen=True, eq=False)
class RangeTable:
    """All UWB ranges of a session.

    ``frame`` has the columns of :data:`RANGE_COLUMNS` (``sigma`` NaN where the file
    gives none) followed by any extra columns of the input, carried through unchanged.
    Rows are sorted by time (stable), ``pair`` is :func:`pair_name` of from/to.
    """

    frame: pd.DataFrame
    source: str = ""

    @classmethod
    def with_id_codes(
        cls, frame: pd.DataFrame, source: str, id_codes: tuple[np.ndarray, np.ndarray, np.ndarray]
    ) -> RangeTable:
        """A table whose :attr:`id_codes` its reader already has (what ``frame`` gives)."""
        table = cls(frame, source=source)
        table.__dict__["id_codes"] = id_codes
        return table

    @property
    def extra_columns(self) -> tuple[str, ...]:
        return tuple(c for c in self.frame.columns if c not in RANGE_COLUMNS)

    @property
    def pairs(self) -> tuple[str, ...]:
        """Pairs with at least one range, sorted."""
        return tuple(self.pair_index)

    @functools.cached_property
    def pair_index(self) -> Mapping[str, np.ndarray]:
        """Row positions of each pair (ascending), pairs sorted: one grouping of the table
        instead of a string comparison over every row per pair (45-190 pairs)."""
        codes, names = pd.factorize(self.frame["pair"], sort=True)
        order = np.argsort(codes, kind="stable")
        bounds = np.searchsorted(codes[order], np.arange(len(names) + 1))
        return {str(name): order[bounds[i] : bounds[i + 1]] for i, name in enumerate(names)}

    @functools.cached_property
    def id_codes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(platform ids sorted, code of ``from``, code of ``to`` of every row): integer
        codes to select a platform's rows without comparing strings row by row."""
        both = pd.concat([self.frame["from"], self.frame["to"]], ignore_index=True)
        codes, seen = pd.factorize(both)  # hashed in place: no Python string per row
        found = np.asarray(seen, dtype=object)
        order = sorted(range(found.shape[0]), key=lambda i: found[i])  # ids as text sort
        rank = np.empty(found.shape[0] + 1, dtype=np.intp)
        rank[order] = np.arange(found.shape[0])
        rank[-1] = -1  # missing stays -1
        codes = rank[codes]
        n = len(self.frame)
        return found[order], codes[:n], codes[n:]

    def rows_of(self, platform: str) -> np.ndarray:
        """Row positions (ascending) of the ranges ``platform`` takes part in."""
        ids, first, second = self.id_codes
        at = int(np.searchsorted(ids, platform))
        if at >= ids.shape[0] or ids[at] != platform:
            return np.empty(0, dtype=np.int64)
        return np.flatnonzero((first == at) | (second == at))

    def for_pair(self, pair: str) -> pd.DataFrame:
        """The rows of one pair, in time order."""
        return self.frame.iloc[self.pair_index.get(pair, np.empty(0, dtype=np.int64))]

    def __len__(self) -> int:
        return len(self.frame)


@dataclass(frozen=True)
class SessionConfig:
    """What ``session.toml`` says (every key optional; see docs/formats.md)."""

    name: str = ""
    time_base: TimeBase = "gps_tow"
    gps_week: int | None = None
    #: ENU origin (lat deg, lon deg, height m); None: derived as DATA.md says.
    origin_llh: tuple[float, float, float] | None = None
    platforms: Mapping[str, Platform] = field(default_factory=dict)
    #: UWB ranging 1-sigma, metres; None: estimated adaptively.
    uwb_sigma_m: float | None = None
    #: RTKLIB Q values accepted as reference (1 = fix).
    reference_quality: tuple[int, ...] = (1,)
    #: Other file names: key (``ranges``, ``nav.A``, ``ref.A``, ``mcap``) -> relative path.
    files: Mapping[str, str] = field(default_factory=dict)
    mcap: Mapping[str, object] = field(default_factory=dict)  # [mcap] topics/fields, as given
    time_offsets: Literal["estimate"] | Mapping[str, float] = field(default_factory=dict)
    trust_declared: bool = False  # [calibration]: contradicted drifts kept (run/declared.py)


@dataclass(frozen=True, eq=False)
class Session:
    """One recording, read and validated: the input of every stage."""

    config: SessionConfig
    #: Every platform that has navigation (or is an anchor), by id.
    platforms: Mapping[str, Platform]
    nav: Mapping[str, Trajectory]
    reference: Mapping[str, Trajectory]
    ranges: RangeTable
    #: ENU origin actually used (lat deg, lon deg, height m).
    origin_llh: tuple[float, float, float]
    #: Where the session was read from (directory or .mcap file).
    root: Path
    #: Every input file read, for run.json hashes.
    inputs: tuple[Path, ...] = ()
    #: What the readers decided that a user should know (defaults used, rows sorted, ...).
    notes: tuple[str, ...] = ()
    #: Raw-sensor files found beside the navigation (or the bag holding them).
    sensor_files: tuple[SensorFile, ...] = ()
    #: Raw IMU samples by platform (imu_<ID>.csv, sensor_msgs/msg/Imu), read and checked.
    imu: Mapping[str, ImuData] = field(default_factory=dict)
    #: Odometer samples by platform (odo_<ID>.csv, nav_msgs/msg/Odometry twist).
    odometer: Mapping[str, OdometerData] = field(default_factory=dict)
    #: GPS observations by platform (obs_<ID>.*): coopproc.gnss.receiver.GnssReceiver
    gnss: Mapping[str, Any] = field(default_factory=dict)
    clock: Any = None  # coopproc.clocks.ClockReport, once estimated (coopproc.checks.clock)

    @property
    def name(self) -> str:
        return self.config.name or self.root.name

    @property
    def platform_ids(self) -> tuple[str, ...]:
        return tuple(sorted(self.platforms))

    def moving_platforms(self) -> tuple[str, ...]:
        """Ids of platforms that are not anchors, sorted."""
        return tuple(p for p in self.platform_ids if self.platforms[p].role != "anchor")

    def without_samples(self) -> Session:
        """This session without its recorded samples (nav, reference, range rows, IMU,
        odometer, GNSS): all that writing a run's outputs reads once the pipeline is done
        (a day of 10 platforms holds 1.1 GB of samples the page workers need not inherit)."""
        rows = self.ranges.frame.iloc[:0].copy()  # a copy: a view would keep the rows
        return dataclasses.replace(
            self, nav={}, reference={}, ranges=RangeTable(rows, self.ranges.source), imu={},
            odometer={}, gnss={},
        )  # fmt: skip


@dataclass(frozen=True, eq=False)
class Result:
    """Everything ``coopproc run`` computes; each table maps to one output CSV."""

    ranges: pd.DataFrame  # RANGES_OUT_COLUMNS -> ranges.csv
    di: pd.DataFrame  # DI_COLUMNS -> di.csv
    nlos_events: pd.DataFrame  # NLOS_EVENT_COLUMNS -> nlos_events.csv
    nlos_estimates: pd.DataFrame  # NLOS_ESTIMATE_COLUMNS -> nlos_estimates.csv
    positions: pd.DataFrame  # POSITIONS_COLUMNS -> positions.csv
    metrics: pd.DataFrame  # METRICS_COLUMNS -> metrics.csv
    position_metrics: pd.DataFrame  # POSITION_METRICS_COLUMNS -> position_metrics.csv
    states: pd.DataFrame | None = None  # STATES_COLUMNS -> states.csv (INS methods)
    dr_states: pd.DataFrame | None = None  # DR_STATES_COLUMNS -> dr_states.csv (state "dr")
    range_weights: pd.DataFrame | None = None  # names.RANGE_WEIGHTS_COLUMNS -> range_weights.csv
    lsq_quality: pd.DataFrame | None = None  # names.LSQ_QUALITY_COLUMNS -> lsq_quality.csv
