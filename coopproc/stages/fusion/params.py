"""The cooperative fusion's configuration (run config ``[fusion]``): :class:`FusionParams`.

Every figure with its meaning and its checks; docs/methods-fusion.md says where each
default was measured.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from coopproc.configtools import from_table
from coopproc.stages.shared.lsq import LsqParams

__all__ = ["FusionParams", "fusion_params_from_toml"]


@dataclass(frozen=True)
class FusionParams:
    """Cooperative fusion (run config ``[fusion]``)."""

    robust: bool = field(
        default=True,
        metadata={"help": "IGG-III robust factor on the innovations (paper 002 eq. (18))"},
    )
    k0: float = field(
        default=3.0,
        metadata={"help": "IGG-III k0, full weight up to |s| = k0 (paper: 2.5..3.5)"},
    )
    k1: float = field(
        default=4.0,
        metadata={"help": "IGG-III k1, rejected beyond |s| = k1 (paper: 3.5..4.5)"},
    )
    mad_floor: float = field(
        default=1.0,
        metadata={"help": "lower bound of the MAD unit-weight sigma of eq. (20)"},
    )
    mad_window: int = field(
        default=50,
        metadata={
            "help": "eq. (20) MAD over the epoch's innovations and this many earlier ones "
            "(0: the epoch's alone; with one range per epoch the robust factor never acts)"
        },
    )
    smoother: bool = field(
        default=True, metadata={"help": "RTS fixed-interval smoother (paper 003 sec. 2.8)"}
    )
    self_calibrate: bool = field(
        default=True,
        metadata={
            "help": "per-pair ranging sigma from the post-fit residuals and drift inflation "
            "of platforms whose range innovations are inconsistent (fusion_calibration.py)"
        },
    )
    dims: int = field(
        default=2,
        metadata={"help": "2: estimate east/north (height from nav); 3: east/north/up"},
    )
    range_sigma_m: float = field(
        default=0.15,
        metadata={"help": "range 1-sigma (m) for rows without one when session.toml has none"},
    )
    drift_sigma_mps: float = field(
        default=0.02,
        metadata={"help": "dead-reckoning drift 1-sigma (m/s) of platforms without one"},
    )
    drift_correlation_s: float = field(
        default=5.0,
        metadata={"help": "correlation time (s) of the DR velocity error; 0: q = (sigma dt)^2"},
    )
    leader_sigma_m: float = field(
        default=0.05,
        metadata={"help": "1-sigma (m) of a leader's own fix when its nav has no sigma"},
    )
    initial_sigma_m: float = field(
        default=1.0,
        metadata={"help": "1-sigma (m) of a follower's first position when its nav has none"},
    )
    init_from_anchors: bool = field(
        default=True,
        metadata={"help": "start tags from a robust LSQ fix at the first epoch if anchors allow"},
    )
    epoch_merge_s: float = field(
        default=0.0,
        metadata={"help": "successive range times closer than this (s) form one epoch"},
    )
    leader_fix: str = field(
        default="pooled",
        metadata={
            "help": "when a leader's own fix is an observation: 'pooled' (once per nav "
            "sample, with the information of the range epochs it stands for), 'epoch' "
            "(at every range epoch) or 'nav' (once per nav sample, its own sigma); "
            "docs/methods-fusion.md"
        },
    )
    state: str = field(
        default="dr",
        metadata={
            "help": "'dr': each follower's state carries its dead reckoning's heading "
            "correction, heading rate and odometer scale (docs/methods-fusion.md); "
            "'position': positions only, paper 000's own fusion"
        },
    )
    dr_position_sigma_mps: float = field(
        default=0.005,
        metadata={
            "help": "state 'dr': a follower's residual DR velocity noise, 1-sigma (m/s, "
            "white: q = sigma^2 dt per axis); its declared drift_sigma is the total drift "
            "that the DR states now explain"
        },
    )
    dr_distance_noise_m: float = field(
        default=0.012,
        metadata={
            "help": "state 'dr': a follower's odometer distance noise (m per sqrt(m) "
            "travelled, per axis)"
        },
    )
    dr_heading_noise_deg: float = field(
        default=0.0,
        metadata={
            "help": "state 'dr': a follower's heading noise (deg per sqrt(m) travelled: "
            "wheel slip, turns)"
        },
    )
    heading_sigma_deg: float = field(
        default=2.0,
        metadata={"help": "state 'dr': 1-sigma of the initial heading correction (deg)"},
    )
    heading_rate_sigma_dph: float = field(
        default=30.0,
        metadata={"help": "state 'dr': 1-sigma of the initial heading rate, gyro bias (deg/h)"},
    )
    heading_walk_dpsh: float = field(
        default=2.0,
        metadata={"help": "state 'dr': heading random walk (deg/sqrt(h))"},
    )
    heading_rate_walk_dphpsh: float = field(
        default=10.0,
        metadata={"help": "state 'dr': heading-rate random walk (deg/h per sqrt(h))"},
    )
    scale_sigma: float = field(
        default=0.01,
        metadata={"help": "state 'dr': 1-sigma of the initial odometer scale error (0.01 = 1 %)"},
    )
    scale_walk_psh: float = field(
        default=0.001,
        metadata={"help": "state 'dr': odometer scale random walk (per sqrt(h))"},
    )
    dr_noise_search: bool = field(
        default=False,
        metadata={
            "help": "state 'dr': scale the followers' DR noise figures by the factor whose "
            "range innovations are the most likely (calibration_dr.py)"
        },
    )
    dr_noise_cv: bool = field(
        default=True,
        metadata={
            "help": "state 'dr': scale the followers' DR noise figures by the factor whose "
            "fusions best predict the ranges of pairs left out of them (leave-pair-out "
            "cross-validation of the observed ranges' fusion, only tightening; the RN "
            "fusion takes its factor; calibration_dr.py)"
        },
    )
    dr_noise_cv_smoothed: bool = field(
        default=True,
        metadata={
            "help": "with dr_noise_cv: a smoothed range set's fusion (DI) takes the observed "
            "fusion's DR noise factor too (false: the [fusion] figures; docs/methods-fusion.md)"
        },
    )
    robust_smoother_iterations: int = field(
        default=1,
        metadata={
            "help": "state 'dr': times the IGG-III factors are taken afresh from the "
            "smoothed solution and the filter and smoother rerun with them (robust_refit.py; "
            "0, and always with state 'position': the forward pass's factors, as papers "
            "002/003 write it)"
        },
    )
    dr_fault_window_s: float = field(
        default=5.0,
        metadata={
            "help": "state 'dr': the span (s) of a platform's ranges judged together for a "
            "jump of its dead reckoning (a wheel slip), given as process noise (dr_faults.py, "
            "docs/methods-fusion.md#dr-jumps; 0: off; always off with state 'position')"
        },
    )
    carry_weights: bool = field(
        default=False,
        metadata={
            "help": "a smoothed range set's fusion (DI) weighs each range by the IGG-III "
            "factor the observed fusion gives it against its own solution (carried_weights.py)"
        },
    )
    cp_folds: int = field(
        default=0,
        metadata={
            "help": "> 0: the ranging stage's CP DI of a pair comes from a fusion without "
            "its own ranges, the pairs split into this many folds, one forward fusion each "
            "(leave_out.py; 4 is the tested setting); 0: paper 000's cooperative solution "
            "of all ranges"
        },
    )
    dr_states_every_s: float = field(
        default=1.0,
        metadata={"help": "state 'dr': the DR states are reported (dr_states.csv) this often (s)"},
    )
    cp_state: str = field(
        default="auto",
        metadata={
            "help": "the ranging stage's cooperative solution (its CP DI): 'position' (paper "
            "000's position-state fusion of the navigation as recorded), 'corrected' (the "
            "same fusion of the followers' navigation corrected by the causal DR states, "
            "state 'dr' only), 'dr' (the DR-state fusion's forward solution), 'auto' "
            "('corrected' with state 'dr', else 'position'); docs/methods-ranging.md#cp-state"
        },
    )
    lsq: LsqParams = field(
        default_factory=LsqParams,
        metadata={"help": "robust LSQ from anchors ([fusion.lsq])"},
    )

    @property
    def cp_mode(self) -> str:
        """``cp_state`` with ``auto`` resolved: ``corrected`` when the fusion has DR states,
        ``position`` (paper 000's own fusion) when it has the position state only."""
        if self.cp_state != "auto":
            return self.cp_state
        return "corrected" if self.state == "dr" else "position"

    def __post_init__(self) -> None:
        if not 2.5 <= self.k0 <= 3.5:
            raise ValueError(f"k0 = {self.k0} is outside 2.5..3.5 (paper 002 eq. (18))")
        if not 3.5 <= self.k1 <= 4.5 or self.k1 <= self.k0:
            raise ValueError(f"k1 = {self.k1} must be in 3.5..4.5 and above k0 = {self.k0}")
        if self.dims not in (2, 3):
            raise ValueError(f"dims = {self.dims}, expected 2 or 3")
        for name in ("range_sigma_m", "drift_sigma_mps", "leader_sigma_m", "initial_sigma_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected > 0")
        if self.state not in ("dr", "position"):
            raise ValueError(f"state = {self.state!r}, expected 'dr' or 'position'")
        if self.cp_state not in ("auto", "position", "corrected", "dr"):
            raise ValueError(
                f"cp_state = {self.cp_state!r}, expected 'auto', 'position', 'corrected' or 'dr'"
            )
        if self.cp_state not in ("auto", "position") and self.state != "dr":
            raise ValueError(f"cp_state = {self.cp_state!r} needs state = 'dr' (its DR states)")
        for name in (
            "dr_position_sigma_mps", "dr_distance_noise_m", "dr_heading_noise_deg",
            "heading_sigma_deg", "heading_rate_sigma_dph",
            "heading_walk_dpsh", "heading_rate_walk_dphpsh", "scale_sigma", "scale_walk_psh",
        ):  # fmt: skip
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected >= 0")
        if not self.dr_fault_window_s >= 0:
            raise ValueError(f"dr_fault_window_s = {self.dr_fault_window_s}, expected >= 0")
        if self.robust_smoother_iterations < 0:
            raise ValueError(
                f"robust_smoother_iterations = {self.robust_smoother_iterations}, expected >= 0"
            )
        if self.cp_folds < 0:
            raise ValueError(f"cp_folds = {self.cp_folds}, expected >= 0")
        if not self.dr_states_every_s > 0:
            raise ValueError(f"dr_states_every_s = {self.dr_states_every_s}, expected > 0")
        if self.leader_fix not in ("epoch", "nav", "pooled"):
            raise ValueError(
                f"leader_fix = {self.leader_fix!r}, expected 'epoch', 'nav' or 'pooled'"
            )
        if self.mad_window < 0:
            raise ValueError(f"mad_window = {self.mad_window}, expected >= 0")
        if self.mad_floor < 0 or self.epoch_merge_s < 0 or self.drift_correlation_s < 0:
            raise ValueError("mad_floor, epoch_merge_s and drift_correlation_s must be >= 0")


def fusion_params_from_toml(table: Mapping[str, Any], where: str = "run config") -> FusionParams:
    """FusionParams from a whole run-config TOML table (only ``[fusion]`` is read).

    ``where`` names the file for messages.
    """
    return from_table(FusionParams, table.get("fusion"), f"{where} [fusion]")
