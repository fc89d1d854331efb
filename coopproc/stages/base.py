"""What a stage of the chain takes and gives: the typed contract between stages and runner.

Two kinds of stage (docs/architecture.md, docs/extending.md):

- a **range processor** (:class:`RangeStage`) takes the session's range table (one row
  per range epoch and pair: ``time, pair, observed, reference``) and, if it declares
  ``needs_cp``, the cooperative solution fused with the observed ranges; it gives one
  distance column per method it produces (``rn``, ``di``, ``median``, ...), aligned with
  the table's rows, and optionally NLOS flags, events and diagnostics;
- a **position estimator** (:class:`PositionStage`) takes one range set (the observed
  ranges or one processed method's) and gives each platform's trajectory.

Stages never read files, print, or convert frames; the runner (:mod:`coopproc.run.pipeline`)
orders them by their declared inputs and outputs, times them, and turns their products
into the output tables.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray, Session, Trajectory

__all__ = [
    "CAPABILITIES",
    "RESERVED_NAMES",
    "CalibrationWindows",
    "LeftOutCP",
    "NavStates",
    "PositionCalibration",
    "PositionInput",
    "PositionProduct",
    "PositionStage",
    "RangeCalibration",
    "RangeInput",
    "RangeProduct",
    "RangeStage",
    "session_capabilities",
]

#: Names no method may take: columns of ranges.csv that are not methods, and the
#: positions.csv methods the runner adds itself.
RESERVED_NAMES: frozenset[str] = frozenset(
    {"time", "pair", "observed", "reference", "nlos_flag", "nlos_estimate", "outlier", "nav"}
)

#: What a session can give a stage (a registry entry's ``requires``), with what each means.
CAPABILITIES: Mapping[str, str] = {
    "navigation": "a moving platform (leader or follower) with its own navigation (dead "
    "reckoning or GNSS/INS)",
    "anchors": "fixed anchors (role anchor) with known positions",
    "tags": "platforms without navigation (role tag)",
    "imu": "raw IMU samples (imu_<ID>.csv)",
    "odometer": "an odometer (odo_<ID>.csv)",
    "gnss": "raw GPS observations (obs_<ID>.*)",
}


def session_capabilities(session: Session) -> frozenset[str]:
    """The :data:`CAPABILITIES` ``session`` has."""
    roles = {p.role for p in session.platforms.values()}
    navigating = any(session.platforms[p].role in ("leader", "follower") for p in session.nav)
    have = {
        "navigation": navigating,
        "anchors": "anchor" in roles,
        "tags": "tag" in roles,
        "imu": bool(session.imu),
        "odometer": bool(session.odometer),
        "gnss": bool(session.gnss),
    }
    return frozenset(k for k, v in have.items() if v)


class CalibrationWindows(Protocol):
    """A range method's self-calibration per window (run.json's ``windows``): one value
    per calibration window, in time order."""

    @property
    def starts_s(self) -> FloatArray: ...  # window start times (session time base)
    @property
    def white_m(self) -> FloatArray: ...  # UWB white noise, m
    @property
    def detect_m(self) -> FloatArray: ...  # 1-sigma of the detection threshold, m
    @property
    def growth_m2ps(self) -> FloatArray: ...  # DI growth (process noise), m^2/s
    @property
    def gain(self) -> FloatArray: ...  # steady-state gain of the range update
    @property
    def ranges_only(self) -> NDArray[np.bool_]: ...  # True: the window leans on the ranges
    @property
    def estimated(self) -> NDArray[np.bool_]: ...  # True: from the window's own data


class RangeCalibration(Protocol):
    """What a range method's filter used for one pair and where it came from: what
    run.json's ``calibration.ranging`` block, the terminal's self-calibration lines and
    nlos_scores.csv's ``mode`` read (:class:`RangeProduct.calibration`; the DI-Based and
    RN-Based methods' :class:`coopproc.stages.ranging.stage.PairCalibration`)."""

    @property
    def declared_sigma_m(self) -> float: ...  # session.toml [uwb] sigma (NaN: none)
    @property
    def white_sigma_m(self) -> float: ...  # range noise of the filter's update
    @property
    def detect_sigma_m(self) -> float: ...  # 1-sigma behind the detection threshold
    @property
    def growth_m2ps(self) -> float: ...  # DI process noise, m^2/s (0: none)
    @property
    def source(self) -> str: ...  # "data", "session.toml", "adaptive" or "default"
    @property
    def gain(self) -> float: ...  # steady-state gain of the range update (NaN: none)
    @property
    def passthrough(self) -> bool: ...  # every window ranges-only
    @property
    def ranges_only_fraction(self) -> float: ...  # share of epochs in ranges-only windows
    @property
    def local(self) -> CalibrationWindows | None: ...  # per window (None: not calibrated)
    @property
    def cp_source(self) -> str: ...  # where the CP DI came from ("all ranges", a fold)


class PositionCalibration(Protocol):
    """What a position estimator's self-calibration estimated, per range set: what
    run.json's ``calibration.fusion`` block and the terminal read
    (:class:`PositionProduct.calibration`; the fusion's
    :class:`coopproc.stages.fusion.calibration.FusionCalibration`)."""

    @property
    def pair_sigma_m(self) -> Mapping[str, float]: ...  # ranging 1-sigma used per pair
    @property
    def pair_bias_m(self) -> Mapping[str, float]: ...  # median post-fit residual per pair
    @property
    def platform_nis(self) -> Mapping[str, float]: ...  # median NIS / 0.455 per platform
    @property
    def drift_scale(self) -> Mapping[str, float]: ...  # factor on a platform's drift sigma
    @property
    def notes(self) -> tuple[str, ...]: ...
    @property  # the jumps of a platform's dead reckoning found: (platform, time, size m)
    def dr_jumps(self) -> tuple[tuple[str, float, float], ...]: ...


@dataclass(frozen=True)
class LeftOutCP:
    """The cooperative solution of each pair fused without the pair's own ranges
    (:mod:`coopproc.stages.fusion.leave_out`).

    ``trajectories``: pair -> {moving platform: forward positions at the pair's range
    times}, for the pairs that have one; ``fold``: pair -> its fold (0-based), every pair;
    ``folds``: how many; ``kept``: pair -> why it keeps the solution of all ranges.
    """

    trajectories: Mapping[str, Mapping[str, Trajectory]]
    fold: Mapping[str, int]
    folds: int
    kept: Mapping[str, str]


@dataclass(frozen=True, eq=False)
class RangeInput:
    """What a range processor gets."""

    session: Session
    #: one row per range epoch and pair, pairs in session order, each by time:
    #: ``time, pair, observed, reference`` (reference NaN where there is none)
    table: pd.DataFrame
    #: the cooperative solution (fusion with the observed ranges) when the stage
    #: declares ``needs_cp``, else None
    cp: Mapping[str, Trajectory] | None
    #: each pair's cooperative solution without its own ranges (the causal one), when the
    #: stage declares ``needs_cp`` and the fusion gives it; None: ``cp`` for every pair
    cp_left_out: LeftOutCP | None = None
    #: the cooperative fusion's DR states (dr_states.csv's columns, one method) when it
    #: carries them: the ranging stage corrects the followers' DR displacements by them
    dr_states: pd.DataFrame | None = None


@dataclass(frozen=True, eq=False)
class RangeProduct:
    """What a range processor gives; every array is aligned with ``RangeInput.table``."""

    #: method -> processed distance (m) at every row; NaN where the method has none
    values: Mapping[str, FloatArray]
    #: method -> (NLOS flag 0/1, current NLOS estimate m) at every row, for methods
    #: that detect NLOS
    nlos: Mapping[str, tuple[NDArray[np.int64], FloatArray]] = field(default_factory=dict)
    #: rows of nlos_events.csv / nlos_estimates.csv (coopproc.model columns), or None
    nlos_events: pd.DataFrame | None = None
    nlos_estimates: pd.DataFrame | None = None
    #: rows of di.csv, or None
    di: pd.DataFrame | None = None
    #: pair -> (UWB sigma used, where it came from), for run.json
    sigma: Mapping[str, tuple[float, str]] = field(default_factory=dict)
    #: (pair, method) -> self-calibration facts (coopproc.stages.ranging.stage.PairCalibration)
    calibration: Mapping[tuple[str, str], RangeCalibration] = field(default_factory=dict)
    #: 1 at the rows whose range the processor rejected as a gross outlier, or None
    outlier: NDArray[np.int64] | None = None
    #: method -> the distances its fusion takes instead of ``values`` (every row), for a
    #: method whose output is smoothed over time but whose fusion takes the observed
    #: ranges less its NLOS estimates (not smoothed: ``[ranging.di] fusion_input``)
    fusion_values: Mapping[str, FloatArray] = field(default_factory=dict)


@dataclass(frozen=True)
class RangeStage:
    """A registry entry for a range processor."""

    name: str
    #: the methods it can produce (range-table columns), in its preferred order
    methods: tuple[str, ...]
    #: frozen dataclass of its parameters, every field with a default and a help
    params_type: type
    #: the run-config table its parameters live in (dotted for a sub-table: "fusion.lsq")
    section: str
    #: (input, params, the requested subset of ``methods``) -> product
    run: Callable[[RangeInput, Any, tuple[str, ...]], RangeProduct]
    #: one line for ``coopproc config``
    help: str
    #: True: it needs the cooperative solution with the observed ranges (input ``cp``)
    needs_cp: bool = False
    #: the :data:`CAPABILITIES` a session needs for it (``coopproc config --session``
    #: marks a missing one; shown, not enforced: the family rules and checks refuse)
    requires: frozenset[str] = frozenset({"navigation"})
    #: the methods whose ranges are smoothed over time (errors correlated from epoch to
    #: epoch, and with the dead reckoning that smoothed them): their fusion keeps the
    #: [fusion] DR figures (calibration_dr.py)
    smoothed: tuple[str, ...] = ()
    #: method -> (short, long) name in the terminal summary (``DI``, ``DI-Based``); a
    #: method without one prints as it is named
    labels: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    #: the methods whose NLOS decisions fill ranges.csv's ``nlos_flag`` / ``nlos_estimate``
    #: and head the summary, in preference (DATA.md: the DI method's); a chain without any
    #: takes the first method that detects NLOS
    nlos_primary: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class PositionInput:
    """What a position estimator gets for one range set."""

    session: Session
    #: the range set's name (``observed``, ``rn``, ``di``, ...)
    range_set: str
    #: columns ``time, from, to, range, sigma`` (sigma NaN: the estimator's default)
    ranges: pd.DataFrame
    #: epochs of the reported trajectories: the range epochs, or the navigation rate
    output: Literal["ranges", "nav"]
    #: this estimator's product on the observed ranges, for the processed sets (None for
    #: the observed set itself)
    observed: PositionProduct | None = None
    #: True: also give the solution at the range epochs as ``cp`` (a range processor
    #: needs the cooperative solution)
    want_cp: bool = False
    #: True: the range set's ranges are smoothed over time (:attr:`RangeStage.smoothed`,
    #: unless the product gives its fusion other values: ``RangeProduct.fusion_values``)
    smoothed: bool = False


@dataclass(frozen=True, eq=False)
class NavStates:
    """Velocity and attitude of one platform by a method that estimates them (states.csv).

    ``time_s`` (n,); ``vel_enu_mps`` (n, 3); ``att_deg`` (n, 3) roll (right side down),
    pitch (nose up), yaw (heading, clockwise from north, 0..360); the sigmas (n, 3) 1-sigma
    of each, NaN where unknown.
    """

    time_s: FloatArray
    vel_enu_mps: FloatArray
    att_deg: FloatArray
    sigma_vel_mps: FloatArray
    sigma_att_deg: FloatArray


@dataclass(frozen=True, eq=False)
class PositionProduct:
    """What a position estimator gives for one range set."""

    #: platform -> the reported trajectory (smoothed where the estimator smooths)
    positions: Mapping[str, Trajectory]
    #: (causal, smoothed) solutions at the range epochs, when ``want_cp`` was asked
    cp: tuple[Mapping[str, Trajectory], Mapping[str, Trajectory]] | None = None
    #: the causal solution of each pair without its own ranges, when ``want_cp`` was asked
    #: and the estimator gives it
    cp_left_out: LeftOutCP | None = None
    #: self-calibration facts for run.json (coopproc.stages.fusion.calibration), or None
    calibration: PositionCalibration | None = None
    notes: tuple[str, ...] = ()
    #: platform -> velocity and attitude, for estimators that have them (states.csv)
    states: Mapping[str, NavStates] = field(default_factory=dict)
    #: the followers' dead-reckoning errors, for estimators that estimate them
    #: (DR_STATES_COLUMNS with an empty method; dr_states.csv)
    dr_states: pd.DataFrame | None = None
    #: the same as the causal filter estimates them (the ranging stage's DR DI)
    dr_states_forward: pd.DataFrame | None = None
    #: each range the estimator used and its robust factor, for estimators that weigh
    #: them (RANGE_WEIGHTS_COLUMNS but method and rejected; range_weights.csv)
    range_weights: pd.DataFrame | None = None
    #: every epoch of the anchor least squares and its decision (LSQ_QUALITY_COLUMNS;
    #: lsq_quality.csv), for the ``lsq*`` estimators
    lsq_quality: pd.DataFrame | None = None


@dataclass(frozen=True)
class PositionStage:
    """A registry entry for a position estimator."""

    name: str
    params_type: type
    section: str
    run: Callable[[PositionInput, Any], PositionProduct]
    help: str
    #: True: the positions.csv method of range set ``s`` is ``s`` itself (the cooperative
    #: fusion, DATA.md's ``observed``/``rn``/``di``); False: ``name`` for the observed
    #: set and ``name_s`` for the others
    named_by_range_set: bool = False
    #: True: it can provide the cooperative solution a range processor needs
    provides_cp: bool = False
    #: True: the processed sets' runs take this estimator's product on the observed set
    needs_observed: bool = False
    #: raises StageError when the session cannot give this estimator anything (checked
    #: before any stage runs); None: no check
    check: Callable[[Session], None] | None = None
    #: True: it positions from ranges alone (no navigation needed), so it also positions
    #: ``tag`` platforms; False: it runs on the session without tags and their ranges
    uwb_only: bool = False
    #: True: it runs on the observed ranges only, not on each processed range set
    observed_only: bool = False
    #: the :data:`CAPABILITIES` a session needs for it (``check`` says why in detail)
    requires: frozenset[str] = frozenset({"navigation"})

    def method(self, range_set: str) -> str:
        """The positions.csv method of this estimator on ``range_set``."""
        if self.named_by_range_set:
            return range_set
        return self.name if range_set == "observed" else f"{self.name}_{range_set}"
