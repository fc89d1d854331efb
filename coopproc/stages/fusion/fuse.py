"""Cooperative positioning: a centralized EKF over every moving platform (paper 000 3.1.1).

The processing centre of paper 000 section 3.1.1 fuses each platform's own navigation
with the ranges between platforms. Model (see ``fusion_ekf`` for the compiled loops):

- state: the ENU positions of all moving platforms, horizontal by default (``dims = 2``,
  heights taken from each platform's own navigation), or 3D; with ``state = "dr"`` each
  follower's heading correction, heading rate and odometer scale after them
  (:mod:`~coopproc.stages.fusion.dr_model`: the prediction rotates and scales its DR
  increment, and its position noise is a residual one);
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

Epochs are the distinct range times (optionally merged, ``epoch_merge_s``) of the
ranges whose moving ends both have navigation at that time (``nav_span.py``). With
``state = "dr"`` (default) each follower also carries its dead reckoning's heading,
heading rate and scale (``dr_model.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.memory import release_freed_memory
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.fusion.dr_states import dr_layout, dr_states_table
from coopproc.stages.fusion.ekf import (
    block_size,
    ekf_forward,
)
from coopproc.stages.fusion.inputs import FusionInputs, fusion_inputs
from coopproc.stages.fusion.kernel_types import Navigation, Observations, Process, Robust, Slots
from coopproc.stages.fusion.output import solutions_from_slots
from coopproc.stages.fusion.params import FusionParams, fusion_params_from_toml
from coopproc.stages.fusion.robust_refit import smoothed_gammas
from coopproc.stages.fusion.smoother import mbf_backward
from coopproc.stages.fusion.smoother_rerun import refit_checkpoints

__all__ = ["FusionOutput", "FusionParams", "RangeDecisions", "fuse", "fusion_params_from_toml"]


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
    #: The same as the causal forward filter estimates them (the ranging stage's DR DI
    #: takes these: the answer for a stretch does not depend on what follows it)
    dr_states_forward: pd.DataFrame | None = None
    #: The robust factor of every range as the returned solution used it (the final
    #: pass's: with the robust smoother's refits, the factors of the last refit), for
    #: range_weights.csv; None when the solution was discarded (``discard``).
    decisions: RangeDecisions | None = None


@dataclass(frozen=True, eq=False)
class RangeDecisions:
    """The IGG-III decision on each range row of a fusion (the rows of ``observations``).

    ``source``: each row's row in the range table given to :func:`fuse`; ``residual_m``:
    what the factor judged, the innovation at the prior (paper 002 eq. (18)-(20) in the
    forward filter) or, with the robust smoother (:mod:`~coopproc.stages.fusion.robust_refit`),
    the range's residual against the smoothed solution; ``standardized``: that over its
    sigma and the MAD unit-weight sigma; ``gamma``: the factor (1 full weight, 1e-30
    rejected: beyond ``k1``).
    """

    source: np.ndarray
    residual_m: FloatArray
    standardized: FloatArray
    gamma: FloatArray


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
    dr_states: bool = True,
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
    dr_states : report the DR states (False: ``dr_states`` is None and no pass records
        them; the positions are the same bits; the DR noise cross-validation's fusions
        read the positions only).
    """
    if inputs is None:
        inputs = fusion_inputs(session, ranges, params, output)
    elif inputs.session is not session or inputs.params != params or inputs.output != output:
        raise ValueError("fuse: inputs prepared for another session, params or output")
    dim = params.dims
    moving, epochs, ep_idx = inputs.moving, inputs.epochs, inputs.ep_idx
    obs, rec_ptr, rec_plat = inputs.obs, inputs.rec_ptr, inputs.rec_plat
    source = inputs.source
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
    dr_rec = dr.rec if dr_states else dr.rec[:0]  # the epochs the DR states are reported at
    if dr.active:  # positions first, each follower's DR states after
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
    kernel_obs = Observations(
        obs["ptr"], obs["kind"], obs["a"], obs["b"], obs["anchor"], obs["anchor_table"],
        obs["dz2"], obs["z"], obs["var"],
    )  # fmt: skip
    # the forward states are read for the forward trajectories, or as the solution when no
    # smoother pass follows; else the smoother records its own and the forward pass none
    # (memory, issue 11: four floats per recorded slot, about 0.27 GB per fusion at a day)
    record_forward = forward or not smooth
    slots = Slots(rec_ptr, rec_plat)
    forward_slots = slots if record_forward else Slots(np.zeros_like(rec_ptr), rec_plat[:0])
    if q_squared and dr.active:  # the kernel squares every q_coef
        q_coef = np.where(dr.idx >= 0, np.sqrt(dr.position_q), q_coef)
    nav = Navigation(epochs, nav_t, nav_v, nav_ptr)
    proc = Process(q_coef, q_squared, dt, dr.idx, dr.q)
    rob = Robust(params.robust, params.k0, params.k1, params.mad_floor, params.mad_window)
    xs_f, var_f, gamma, innov, innov_var, cp_x, cp_c, dr_xf, dr_vf, std_innov = ekf_forward(
        x0,
        c0,
        nav,
        proc,
        kernel_obs,
        params.dims,
        rob,
        forward_slots,
        block,
        dr_rec,
        np.zeros(0),
    )
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
    # the forward pass's decisions: the innovation at the prior and its standardized value
    judged: tuple[FloatArray, FloatArray] | None = (table["innovation"].to_numpy(), std_innov[at])
    del innov, innov_var, std_innov, from_id, to_id  # memory (issue 11): the table took them
    release_freed_memory()  # the forward pass's working arrays, before the smoother's
    if smooth and discard is not None and discard(table):
        if not record_forward:  # the caller reads the table only: no trajectories
            return FusionOutput(smoothed={}, forward={}, epochs_s=epochs, observations=table)
        smooth = False
        judged = None  # the caller reads the table only: no decisions kept
    if smooth:
        refits = params.robust_smoother_iterations if params.state == "dr" and params.robust else 0
        # a smoother pass that a refit follows gives its states only: no variances, no DR
        # states (an n^2 product per reported value, ~1 s of 5 at 10 x 1 h)
        xs_s, var_s, dr_xs, dr_vs = mbf_backward(
            cp_x, cp_c, nav, proc, kernel_obs, gamma, dim, slots, block,
            smoothed_sigma and refits == 0, dr_rec=dr_rec if refits == 0 else dr_rec[:0],
        )  # fmt: skip
        for _ in range(refits):
            # the robust factors against the smoothed solution, then the filter and the
            # smoother again with them (robust_refit.py); the forward trajectories stay
            # the causal filter's
            before = gamma
            gamma, resid_m, std_s = smoothed_gammas(
                obs, rec_ptr, rec_plat, xs_s, len(moving), dim, gamma, params.k0,
                params.k1, params.mad_floor, epochs,
            )  # fmt: skip
            # the last refit's decisions (a range without a smoothed residual keeps the
            # forward pass's factor, and its innovation)
            judged = _refit_judged(judged, resid_m[at], std_s[at])
            del resid_m, std_s
            del xs_s, var_s, dr_xs, dr_vs
            # the filter with the refit's factors: the checkpoints after the block of the
            # first changed factor (before it the filter is the same, bit for bit; none
            # changed on 2 of 9 refits of sample_logs, 14-40 % of the epochs precede it
            # on sample_logs and TIERS)
            refit_checkpoints(
                _first_changed_block(before, gamma, obs["ptr"], block, cp_x.shape[0]),
                cp_x, cp_c, nav, proc, kernel_obs, gamma, dim, block,
            )  # fmt: skip
            del before
            xs_s, var_s, dr_xs, dr_vs = mbf_backward(
                cp_x, cp_c, nav, proc, kernel_obs, gamma, dim, slots, block, smoothed_sigma,
                dr_rec=dr_rec,
            )  # fmt: skip
    else:
        xs_s, var_s, dr_xs, dr_vs = xs_f, var_f, dr_xf, dr_vf
    decisions = None
    if judged is not None:
        decisions = RangeDecisions(source, judged[0], judged[1], gamma[at])
    del at, judged
    active = dr.active and dr_states
    dr_table = dr_states_table(moving, epochs, dr, (dr_xs, dr_vs)) if active else None
    dr_forward = dr_states_table(moving, epochs, dr, (dr_xf, dr_vf)) if active else None
    del dr_xf, dr_vf, dr_xs, dr_vs
    # memory (issue 11): the observations and the range rows are spent (unless the caller
    # keeps its inputs for another fusion); free them before the trajectories are built
    del cp_x, cp_c, obs, kernel_obs, gamma, ep_idx, nav, proc, slots
    del nav_t, nav_v, nav_ptr
    # their pages back to the system before the trajectories take more: glibc keeps the
    # smoother's freed blocks (below its mmap threshold), ~0.7 GB at a day (issue 11)
    release_freed_memory()
    where = (session, moving, epochs, rec_ptr, rec_plat, dim, output)
    solutions = [(xs_s, var_s if smoothed_sigma else None, False)]
    if forward:
        solutions.insert(0, (xs_f, var_f if forward_sigma else None, True))
    del xs_f, var_f, xs_s, var_s  # the forward states go once their trajectories are built
    built = solutions_from_slots(*where, solutions)
    held = built.pop(0) if forward else {}
    return FusionOutput(
        smoothed=built[0], forward=held, epochs_s=epochs, observations=table,
        dr_states=dr_table, dr_states_forward=dr_forward, decisions=decisions,
    )  # fmt: skip


def _first_changed_block(
    before: FloatArray, after: FloatArray, ptr: np.ndarray, block: int, n_blocks: int
) -> int:
    """The checkpoint block holding the first observation whose factor the refit changed
    (``n_blocks`` when none did)."""
    changed = np.flatnonzero(before != after)
    if changed.size == 0:
        return n_blocks
    epoch = int(np.searchsorted(ptr, changed[0], side="right")) - 1
    return epoch // block


def _refit_judged(
    forward: tuple[FloatArray, FloatArray] | None, resid_m: FloatArray, std: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """The residuals and standardized values of a refit's factors, the forward pass's
    where the refit kept the forward factor (NaN)."""
    if forward is None:
        return None
    kept = np.isnan(std)
    if kept.any():
        resid_m = np.where(kept, forward[0], resid_m)
        std = np.where(kept, forward[1], std)
    return resid_m, std


def _drift(session: Session, pid: str, params: FusionParams) -> float:
    value = session.platforms[pid].drift_sigma_mps
    return float(value) if value is not None and value > 0 else params.drift_sigma_mps
