"""Configuration of the ranging stages: the ``[ranging]`` table of a run config.

One table with four sub-tables, every key optional (defaults are paper 000's):

```toml
[ranging.di]        # DI smoothing filter, eq. (4)-(7)
[ranging.distance]  # distance filter, eq. (8)
[ranging.nlos]      # detection eq. (9), estimation eq. (10)-(12), adaptive sigma
[ranging.rn]        # RN-Based reference method
[ranging.outliers]  # gross single ranges rejected before the filters
```
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from coopproc.configtools import from_table
from coopproc.stages.ranging.di import DISmoothingParams
from coopproc.stages.ranging.outliers import OutlierParams

__all__ = [
    "DistanceParams",
    "NLOSParams",
    "RNParams",
    "RangingConfig",
    "ranging_config_from_toml",
]


@dataclass(frozen=True)
class DistanceParams:
    """Distance filter, TOML table ``[ranging.distance]``."""

    transition: Literal["aligned", "lagged"] = field(
        default="aligned",
        metadata={
            "help": "aligned: D_k = D_{k-1} + I_k; lagged: eq. (8) as printed, "
            "D_k = D_{k-1} + I_{k-1} (see docs/methods-ranging.md for the measurement)"
        },
    )
    di_sigma_floor_mps: float = field(
        default=0.02,
        metadata={
            "help": "floor of the DI error (relative velocity, m/s) in R_I, scaled over dt "
            "like eq. (7): dead-reckoning DI errors are correlated, R_I must not vanish"
        },
    )
    di_accel_sigma: float = field(
        default=0.5,
        metadata={"help": "relative acceleration 1-sigma (m/s^2) behind w_I: q_I = (a * dt^2)^2"},
    )

    def __post_init__(self) -> None:
        if self.di_sigma_floor_mps < 0:
            raise ValueError(f"di_sigma_floor_mps must be >= 0, found {self.di_sigma_floor_mps}")
        if self.di_accel_sigma < 0:
            raise ValueError(f"di_accel_sigma must be >= 0, found {self.di_accel_sigma}")


@dataclass(frozen=True)
class NLOSParams:
    """NLOS detection and estimation, TOML table ``[ranging.nlos]``."""

    gamma_sigma: float = field(
        default=3.0, metadata={"help": "detection threshold gamma_max in UWB sigmas, eq. (9)"}
    )
    window_s: float = field(
        default=3.0,
        metadata={"help": "estimation time M, seconds: eq. (11) averages epochs t - t0 < M"},
    )
    backdate_s: float = field(
        default=2.0,
        metadata={
            "help": "at detection, earlier epochs (up to this many seconds) whose residual "
            "exceeded onset_fraction * gamma_max start the event; 0 disables"
        },
    )
    onset_fraction: float = field(
        default=0.5, metadata={"help": "back-dating residual threshold, fraction of gamma_max"}
    )
    confirm_fraction: float = field(
        default=0.5,
        metadata={
            "help": "an event whose final estimate is below this fraction of gamma_max is "
            "a false alarm and is unflagged"
        },
    )
    jump_fraction: float = field(
        default=0.5,
        metadata={
            "help": "DI-Based: an event is confirmed only if the ranges alone step up at its "
            "onset by this fraction of its estimate (lines fitted jump_window_s either "
            "side); else it is a dead-reckoning fault (slip, heading jump), not NLOS. 0: off"
        },
    )
    jump_window_s: float = field(
        default=5.0, metadata={"help": "seconds of ranges fitted each side of the onset"}
    )
    suspect_epochs: int = field(
        default=3,
        metadata={
            "help": "residuals beyond onset_fraction * gamma_max are not used; this many in "
            "a row (same sign) are an event too (0 disables)"
        },
    )
    positive_only: bool = field(
        default=True,
        metadata={
            "help": "NLOS lengthens ranges: an event whose estimate is negative re-anchors "
            "the distance on the ranges instead of being held"
        },
    )
    restart_gap_s: float = field(
        default=5.0,
        metadata={
            "help": "a gap between two ranges of a pair longer than this (s) ends any event "
            "and restarts the distance filter on the next range (nothing is propagated "
            "across an outage)"
        },
    )
    max_event_s: float = field(
        default=120.0,
        metadata={"help": "an event longer than this (s) ends and the distance is re-anchored"},
    )
    end_confirm_s: float = field(
        default=1.0,
        metadata={
            "help": "an event ends when the raw residual stays nearer 0 than the estimate "
            "for this long (seconds) ..."
        },
    )
    end_min_epochs: int = field(default=2, metadata={"help": "... and this many epochs"})
    self_calibrate: bool = field(
        default=True,
        metadata={
            "help": "estimate per pair from the data the white UWB noise, the DI process "
            "noise and the innovation spread behind gamma_max (the declared sigma is a "
            "prior); false: the declared or adaptive sigma alone (docs/methods-ranging.md)"
        },
    )
    two_way: bool = field(
        default=True,
        metadata={
            "help": "run the distance filters (DI- and RN-Based) forward and backward in time "
            "and flag NLOS where both runs do, or one run at its own detection of an event "
            "both confirm (false: forward only, as in real time)"
        },
    )
    passthrough_gain: float = field(
        default=0.75,
        metadata={
            "help": "when a distance filter's steady-state gain on the ranges exceeds this "
            "in a calibration window (the dead reckoning is too poor to smooth them), the "
            "window is ranges-only: the ranges pass through less the NLOS the DI method "
            "finds from the ranges alone; RN detects nothing there. 1: never"
        },
    )
    calibration_window_s: float = field(
        default=300.0,
        metadata={
            "help": "the noise, DI growth, gamma_max and the smooth-or-ranges-only decision "
            "are estimated and applied per window of this many seconds (grid fixed at the "
            "pair's first range; docs/methods-ranging.md)"
        },
    )
    adaptive: bool = field(
        default=True,
        metadata={
            "help": "estimate the UWB sigma from the filter innovations when session.toml "
            "gives none (false: use default_sigma_m)"
        },
    )
    adaptive_window_s: float = field(
        default=60.0, metadata={"help": "sliding window of the adaptive sigma, seconds"}
    )
    adaptive_min_epochs: int = field(
        default=10,
        metadata={"help": "innovations needed before the adaptive sigma replaces the initial"},
    )
    default_sigma_m: float = field(
        default=0.15,
        metadata={"help": "UWB sigma (m) when session.toml gives none and adaptive = false"},
    )
    min_sigma_m: float = field(default=0.01, metadata={"help": "floor of the adaptive sigma, m"})

    def __post_init__(self) -> None:
        for name in (
            "gamma_sigma",
            "window_s",
            "default_sigma_m",
            "min_sigma_m",
            "calibration_window_s",
        ):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, found {getattr(self, name)}")
        if self.jump_window_s <= 0:
            raise ValueError(f"jump_window_s must be > 0, found {self.jump_window_s}")
        for name in (
            "backdate_s",
            "onset_fraction",
            "confirm_fraction",
            "end_confirm_s",
            "jump_fraction",
        ):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, found {getattr(self, name)}")
        if self.suspect_epochs < 0:
            raise ValueError(f"suspect_epochs must be >= 0, found {self.suspect_epochs}")
        if self.restart_gap_s <= 0:
            raise ValueError(f"restart_gap_s must be > 0, found {self.restart_gap_s}")
        if self.max_event_s <= self.window_s:
            raise ValueError("max_event_s must be > window_s")
        if self.end_min_epochs < 1:
            raise ValueError(f"end_min_epochs must be >= 1, found {self.end_min_epochs}")
        if self.adaptive_window_s <= 0 or self.adaptive_min_epochs < 1:
            raise ValueError("adaptive_window_s must be > 0 and adaptive_min_epochs >= 1")


@dataclass(frozen=True)
class RNParams:
    """RN-Based reference method, TOML table ``[ranging.rn]``."""

    velocity: Literal["nav", "difference"] = field(
        default="nav",
        metadata={
            "help": "nav: the nav files' vel_* columns where present, else differences; "
            "difference: always central differences of nav positions"
        },
    )
    velocity_sigma_mps: float = field(
        default=0.02,
        metadata={
            "help": "1-sigma (m/s) of a nav file's velocity columns: the RN increments' eq. "
            "(7) term of a platform whose velocity is measured (its position drift is "
            "the term of a differenced velocity)"
        },
    )

    def __post_init__(self) -> None:
        if not self.velocity_sigma_mps >= 0:
            raise ValueError(f"velocity_sigma_mps = {self.velocity_sigma_mps}, expected >= 0")


@dataclass(frozen=True)
class RangingConfig:
    """Everything the ranging stages read, TOML table ``[ranging]``."""

    di: DISmoothingParams = field(
        default_factory=DISmoothingParams, metadata={"help": "DI smoothing, eq. (4)-(7)"}
    )
    distance: DistanceParams = field(
        default_factory=DistanceParams, metadata={"help": "distance filter, eq. (8)"}
    )
    nlos: NLOSParams = field(
        default_factory=NLOSParams, metadata={"help": "NLOS detection / estimation"}
    )
    rn: RNParams = field(default_factory=RNParams, metadata={"help": "RN-Based method"})
    outliers: OutlierParams = field(
        default_factory=OutlierParams,
        metadata={"help": "gross single ranges rejected before the filters"},
    )


def ranging_config_from_toml(table: Mapping[str, Any], where: str = "run config") -> RangingConfig:
    """The ranging configuration from a whole parsed run-config TOML (other tables ignored).

    ``where`` names the file for messages.
    """
    return from_table(RangingConfig, table.get("ranging"), f"{where} [ranging]")
