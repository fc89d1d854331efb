"""Cooperative positioning: a centralized EKF over every moving platform (paper 000 3.1.1).

The processing centre of paper 000 section 3.1.1 fuses each platform's own navigation
with the ranges between platforms. Model (see ``fusion_ekf`` for the compiled loops):

- state: the ENU positions of all moving platforms, horizontal by default (``dims = 2``,
  heights taken from each platform's own navigation), or 3D;
- prediction: each platform's dead-reckoning increment between epochs (its own ``nav``
  interpolated to the epochs) with process noise from its drift sigma (paper 000
  eq. (7): sigma_k, the position drift in a given interval). The drift sigma (m/s) is
  read as the 1-sigma of the dead-reckoning velocity error, correlated over
  ``drift_correlation_s`` = tau (heading and odometer-scale errors persist): the position
  error of such a first-order Gauss-Markov rate is a random walk of variance
  2 sigma^2 tau per second, so an epoch of dt seconds gets q = 2 sigma^2 tau dt per axis,
  whatever the epoch rate (``drift_correlation_s = 0`` gives the plain (sigma dt)^2);
- observations: every range of the epoch (any subset, none is fine), between two moving
  platforms or to an anchor at its known position; each leader's own fix (its nav
  position, with the nav sigma or ``leader_sigma_m``);
- robust update: IGG-III factor on the standardized innovation with the MAD sigma,
  paper 002 eq. (14)-(20) (``filters.robust_factors``);
- RTS fixed-interval smoother over the forward pass (paper 003 section 2.8), on by
  default because coopproc post-processes recorded logs: every epoch may use the whole
  record.

Epochs are the distinct range times (optionally merged, ``epoch_merge_s``) inside the
span where every moving platform has navigation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd

from coopproc.configtools import from_table
from coopproc.memory import release_freed_memory
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.fusion.dr_states import dr_layout, dr_states_table
from coopproc.stages.fusion.ekf import (
    block_size,
    ekf_forward,
)
from coopproc.stages.fusion.inputs import FusionInputs, fusion_inputs
from coopproc.stages.fusion.lsq import LsqParams
from coopproc.stages.fusion.output import solutions_from_slots
from coopproc.stages.fusion.robust_refit import smoothed_gammas
from coopproc.stages.fusion.smoother import mbf_backward

__all__ = ["FusionOutput", "FusionParams", "fuse", "fusion_params_from_toml"]


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
        default="epoch",
        metadata={
            "help": "when a leader's own fix is an observation: 'epoch' (every range epoch) "
            "or 'nav' (once per nav sample; cheaper with many pairs, see docs/methods-fusion.md)"
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
    robust_smoother_iterations: int = field(
        default=1,
        metadata={
            "help": "times the IGG-III factors are taken afresh from the smoothed solution "
            "and the filter and smoother rerun with them (robust_refit.py; 0: the forward "
            "pass's factors, as papers 002/003 write it)"
        },
    )
    dr_states_every_s: float = field(
        default=1.0,
        metadata={"help": "state 'dr': the DR states are reported (dr_states.csv) this often (s)"},
    )
    lsq: LsqParams = field(
        default_factory=LsqParams,
        metadata={"help": "robust LSQ from anchors ([fusion.lsq])"},
    )

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
        for name in (
            "dr_position_sigma_mps", "dr_distance_noise_m", "dr_heading_noise_deg",
            "heading_sigma_deg", "heading_rate_sigma_dph",
            "heading_walk_dpsh", "heading_rate_walk_dphpsh", "scale_sigma", "scale_walk_psh",
        ):  # fmt: skip
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} = {getattr(self, name)}, expected >= 0")
        if self.robust_smoother_iterations < 0:
            raise ValueError(
                f"robust_smoother_iterations = {self.robust_smoother_iterations}, expected >= 0"
            )
        if not self.dr_states_every_s > 0:
            raise ValueError(f"dr_states_every_s = {self.dr_states_every_s}, expected > 0")
        if self.leader_fix not in ("epoch", "nav"):
            raise ValueError(f"leader_fix = {self.leader_fix!r}, expected 'epoch' or 'nav'")
        if self.mad_window < 0:
            raise ValueError(f"mad_window = {self.mad_window}, expected >= 0")
        if self.mad_floor < 0 or self.epoch_merge_s < 0 or self.drift_correlation_s < 0:
            raise ValueError("mad_floor, epoch_merge_s and drift_correlation_s must be >= 0")


def fusion_params_from_toml(table: Mapping[str, Any], where: str = "run config") -> FusionParams:
    """FusionParams from a whole run-config TOML table (only ``[fusion]`` is read).

    ``where`` names the file for messages.
    """
    return from_table(FusionParams, table.get("fusion"), f"{where} [fusion]")


@dataclass(frozen=True, eq=False)
class FusionOutput:
    """The fused trajectories of every moving platform.

    ``smoothed`` is the RTS solution when the smoother is on, else the forward one;
    ``forward`` the causal filter. ``observations`` has one row per range used: time
    (epoch), from, to, range, innovation (at the prior, m), innovation_var (its predicted
    variance H C H^T + R, m^2) and gamma (robust factor).
    """

    smoothed: Mapping[str, Trajectory]
    forward: Mapping[str, Trajectory]
    epochs_s: FloatArray
    observations: pd.DataFrame
    #: The followers' dead-reckoning errors as the smoothed solution (the forward one
    #: without a smoother) estimates them, DR_STATES_COLUMNS with an empty method
    #: (:func:`~coopproc.stages.fusion.dr_states.dr_states_table`); None with state
    #: "position".
    dr_states: pd.DataFrame | None = None


def fuse(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    *,
    output: Literal["ranges", "nav"] = "ranges",
    drift_scale: Mapping[str, float] | None = None,
    smoothed_sigma: bool = True,
    discard: Callable[[pd.DataFrame], bool] | None = None,
    inputs: FusionInputs | None = None,
    forward: bool = True,
    forward_sigma: bool = True,
) -> FusionOutput:
    """Fuse every moving platform's navigation with the ranges.

    Parameters
    ----------
    session : platforms, their navigation (``session.nav``) and anchors.
    ranges : columns time, from, to, range[, sigma] (sigma NaN: session.toml ``[uwb]
        sigma``, else ``params.range_sigma_m``); observed or processed ranges.
    params : FusionParams.
    output : ``"ranges"``: trajectories at the range epochs; ``"nav"``: at each
        platform's own navigation times inside the fused span (dead reckoning between
        epochs: the forward correction is held, the smoothed one interpolated).
    smoothed_sigma : the smoothed trajectories' sigmas (False: NaN, and a smoother pass
        about twice as fast with many platforms; forward sigmas are always given).
    discard : called with the observations table after the forward pass; True means the
        caller will only read that table (a self-calibration round to be refitted), so the
        smoother is skipped and ``smoothed`` is the forward solution (empty with
        ``forward=False``: no states were kept). The forward pass is the same either way.
    inputs : :func:`~coopproc.stages.fusion.inputs.fusion_inputs` of these session,
        ranges, params and output, prepared earlier (another fusion of the same range set
        with other drift scales); None: prepared here.
    forward : build the forward trajectories (False: ``forward`` is empty; a caller that
        reads the smoothed solution only saves their time and memory, issue 11).
    forward_sigma : the forward trajectories' sigmas (False: None; a caller that reads
        their positions only, the ranging stage's CP solution, saves 24 bytes a slot).
    """
    if inputs is None:
        inputs = fusion_inputs(session, ranges, params, output)
    elif inputs.session is not session or inputs.params != params or inputs.output != output:
        raise ValueError("fuse: inputs prepared for another session, params or output")
    dim = params.dims
    moving, epochs, ep_idx = inputs.moving, inputs.epochs, inputs.ep_idx
    obs, rec_ptr, rec_plat = inputs.obs, inputs.rec_ptr, inputs.rec_plat
    nav_t, nav_v, nav_ptr = inputs.nav
    from_id, to_id = inputs.from_id, inputs.to_id
    n_ep = epochs.shape[0]
    dt = np.diff(epochs, prepend=epochs[0])
    scale = drift_scale or {}
    drift = np.array([_drift(session, p, params) * scale.get(p, 1.0) for p in moving])
    if params.drift_correlation_s > 0:  # 2 sigma^2 tau dt, see the module docstring
        q_coef = 2.0 * drift**2 * params.drift_correlation_s
        q_squared = False
    else:  # (sigma dt)^2
        q_coef = drift.astype(np.float64)
        q_squared = True
    dr = dr_layout(session, moving, epochs, params, scale)
    if dr.idx.max(initial=-1) >= 0:  # positions first, each follower's DR states after
        n_pos = inputs.x0.shape[0]
        x0 = np.concatenate((inputs.x0, np.zeros(dr.prior.shape[0])))
        c0 = np.zeros((x0.shape[0], x0.shape[0]))
        c0[:n_pos, :n_pos] = inputs.c0
        c0[n_pos:, n_pos:] = np.diag(dr.prior)
        q_coef = np.where(dr.idx >= 0, dr.position_q, q_coef)
    else:
        x0, c0 = inputs.x0, inputs.c0
    del inputs  # memory (issue 11): a caller that keeps none frees them as they are spent
    smooth = params.smoother and n_ep > 1
    block = block_size(n_ep) if smooth else 0
    kernel_obs = (
        obs["ptr"], obs["kind"], obs["a"], obs["b"], obs["anchor"], obs["anchor_table"],
        obs["dz2"], obs["z"], obs["var"],
    )  # fmt: skip
    # the forward states are read for the forward trajectories, or as the solution when no
    # smoother pass follows; else the smoother records its own and the forward pass none
    # (memory, issue 11: four floats per recorded slot, about 0.27 GB per fusion at a day)
    record_forward = forward or not smooth
    forward_slots = (
        (rec_ptr, rec_plat) if record_forward else (np.zeros_like(rec_ptr), rec_plat[:0])
    )
    if q_squared and dr.idx.max(initial=-1) >= 0:  # the kernel squares every q_coef
        q_coef = np.where(dr.idx >= 0, np.sqrt(dr.position_q), q_coef)
    noise = (epochs, nav_t, nav_v, nav_ptr, q_coef, q_squared, dt)
    xs_f, var_f, gamma, innov, innov_var, cp_x, cp_c, dr_xf, dr_vf = ekf_forward(
        x0, c0, *noise, *kernel_obs, params.dims, params.robust, params.k0, params.k1,
        params.mad_floor, params.mad_window, *forward_slots, block, dr.idx, dr.q, dr.rec,
        np.zeros(0),
    )  # fmt: skip
    del forward_slots
    at = obs["at"]  # the range rows' observations, in row (= observation) order
    table = pd.DataFrame(
        {
            "time": epochs[ep_idx],
            "from": from_id,
            "to": to_id,
            "range": obs["z"][at],
            "innovation": innov[at],
            "innovation_var": innov_var[at],
            "gamma": gamma[at],
        },
        copy=False,  # memory (issue 11): fresh arrays and immutable id columns, not copied
    )
    del innov, innov_var, at, from_id, to_id  # memory (issue 11): what the table took is spent
    release_freed_memory()  # the forward pass's working arrays, before the smoother's
    if smooth and discard is not None and discard(table):
        if not record_forward:  # the caller reads the table only: no trajectories
            return FusionOutput(smoothed={}, forward={}, epochs_s=epochs, observations=table)
        smooth = False
    if smooth:
        xs_s, var_s, dr_xs, dr_vs = mbf_backward(
            cp_x, cp_c, *noise, *kernel_obs, gamma, dim, rec_ptr, rec_plat, block,
            smoothed_sigma, dr_idx=dr.idx, dr_q=dr.q, dr_rec=dr.rec,
        )  # fmt: skip
        for _ in range(params.robust_smoother_iterations if params.robust else 0):
            # the robust factors against the smoothed solution, then the filter and the
            # smoother again with them (robust_refit.py); the forward trajectories stay
            # the causal filter's
            gamma = smoothed_gammas(
                obs, rec_ptr, rec_plat, xs_s, len(moving), dim, gamma, params.k0,
                params.k1, params.mad_floor,
            )  # fmt: skip
            del xs_s, var_s, dr_xs, dr_vs, cp_x, cp_c
            *_, cp_x, cp_c, _, _ = ekf_forward(
                x0, c0, *noise, *kernel_obs, params.dims, params.robust, params.k0,
                params.k1, params.mad_floor, params.mad_window, np.zeros_like(rec_ptr),
                rec_plat[:0], block, dr.idx, dr.q, dr.rec[:0], gamma,
            )  # fmt: skip
            xs_s, var_s, dr_xs, dr_vs = mbf_backward(
                cp_x, cp_c, *noise, *kernel_obs, gamma, dim, rec_ptr, rec_plat, block,
                smoothed_sigma, dr_idx=dr.idx, dr_q=dr.q, dr_rec=dr.rec,
            )  # fmt: skip
    else:
        xs_s, var_s, dr_xs, dr_vs = xs_f, var_f, dr_xf, dr_vf
    dr_table = (
        dr_states_table(moving, epochs, dr, (dr_xs, dr_vs)) if dr.idx.max(initial=-1) >= 0 else None
    )
    del dr_xf, dr_vf, dr_xs, dr_vs
    # memory (issue 11): the observations and the range rows are spent (unless the caller
    # keeps its inputs for another fusion); free them before the trajectories are built
    del cp_x, cp_c, obs, kernel_obs, gamma, ep_idx, noise
    del nav_t, nav_v, nav_ptr
    # their pages back to the system before the trajectories take more: glibc keeps the
    # smoother's freed blocks (below its mmap threshold), ~0.7 GB at a day (issue 11)
    release_freed_memory()
    slots = (session, moving, epochs, rec_ptr, rec_plat, dim, output)
    solutions = [(xs_s, var_s if smoothed_sigma else None, False)]
    if forward:
        solutions.insert(0, (xs_f, var_f if forward_sigma else None, True))
    del xs_f, var_f, xs_s, var_s  # the forward states go once their trajectories are built
    built = solutions_from_slots(*slots, solutions)
    held = built.pop(0) if forward else {}
    return FusionOutput(
        smoothed=built[0], forward=held, epochs_s=epochs, observations=table, dr_states=dr_table
    )


def _drift(session: Session, pid: str, params: FusionParams) -> float:
    value = session.platforms[pid].drift_sigma_mps
    return float(value) if value is not None and value > 0 else params.drift_sigma_mps
