"""Cooperative positioning: a centralized EKF over every moving platform (paper 000 3.1.1).

The processing centre of paper 000 section 3.1.1 fuses each platform's own navigation
with the ranges between platforms. Model (see ``fusion_ekf`` for the compiled loops):

- state: the ENU positions of all moving platforms, horizontal by default (``dims = 2``,
  heights taken from each platform's own navigation), or 3D; with ``state = "dr"`` each
  follower's heading correction, heading rate and odometer scale after them
  (:mod:`~coopproc.estimation.dr_model`: the prediction rotates and scales its DR
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
heading rate and scale (:mod:`~coopproc.estimation.dr_model`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.memory import gives_back
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.fusion.dr_faults import confirmed_jumps, jumps_table, spread_jumps
from coopproc.stages.fusion.dr_states import dr_states_table
from coopproc.stages.fusion.ekf import (
    ekf_forward,
)
from coopproc.stages.fusion.inputs import FusionInputs, fusion_inputs
from coopproc.stages.fusion.kernel_types import (
    Process,
    Robust,
    Slots,
    Smoothed,
)
from coopproc.stages.fusion.output import solutions_from_slots
from coopproc.stages.fusion.params import FusionParams, fusion_params_from_toml
from coopproc.stages.fusion.problem import FilterProblem, filter_problem
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
    #: The dead-reckoning jumps the forward filter found (JUMP_COLUMNS: time, platform,
    #: size_m; :mod:`~coopproc.stages.fusion.dr_faults`); empty with state "position".
    dr_jumps: pd.DataFrame | None = None


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
    dr_faults: Literal["apply", "judge", "off"] = "apply",
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
    dr_faults : with DR states, the jumps of a platform's dead reckoning
        (:mod:`~coopproc.stages.fusion.dr_faults`): ``"apply"`` found and given as process
        noise; ``"judge"`` found and reported in ``dr_jumps`` only (the positions are those
        of ``"off"``, bit for bit: the self-calibration's fusions); ``"off"`` not looked for.
    """
    if inputs is not None and (
        inputs.session is not session or inputs.params != params or inputs.output != output
    ):
        raise ValueError("fuse: inputs prepared for another session, params or output")
    # each pass is a function whose working arrays go when it returns (memory.py)
    solved, where = _states(
        session, ranges, params, output, inputs, drift_scale, dr_states, forward, discard,
        (smoothed_sigma, forward_sigma, dr_faults),
    )  # fmt: skip
    epochs = where[2]
    if solved.solutions is None:  # discarded: the caller reads the table only
        return FusionOutput(smoothed={}, forward={}, epochs_s=epochs, observations=solved.table)
    built = solutions_from_slots(*where, solved.solutions)  # each solution's states let go
    held = built.pop(0) if forward else {}
    return FusionOutput(
        smoothed=built[0], forward=held, epochs_s=epochs, observations=solved.table,
        dr_states=solved.dr_states, dr_states_forward=solved.dr_states_forward,
        decisions=solved.decisions, dr_jumps=solved.dr_jumps,
    )  # fmt: skip


@gives_back  # the observations and the range rows, before the trajectories take more
def _states(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    output: Literal["ranges", "nav"],
    inputs: FusionInputs | None,
    drift_scale: Mapping[str, float] | None,
    dr_states: bool,
    forward: bool,
    discard: Callable[[pd.DataFrame], bool] | None,
    how: tuple[bool, bool, str],
) -> tuple[_Solved, tuple[Session, list[str], FloatArray, np.ndarray, np.ndarray, int, str]]:
    """The passes (:func:`_solve`) and the slots their states are at; inputs prepared here
    are spent with the problem, a caller's stay the caller's."""
    problem = filter_problem(
        inputs if inputs is not None else fusion_inputs(session, ranges, params, output),
        session, params, drift_scale, dr_states, forward,
    )  # fmt: skip
    solved = _solve(problem, params, discard, how, forward)
    where = (
        session, problem.moving, problem.epochs, problem.rec_ptr, problem.rec_plat,
        params.dims, output,
    )  # fmt: skip
    return solved, where


@dataclass(frozen=True, eq=False)
class _Solved:
    """The fusion's passes done: the observations table, and the solutions to build
    trajectories from (:func:`solutions_from_slots`; None: discarded)."""

    table: pd.DataFrame
    solutions: list[tuple[FloatArray, FloatArray | None, bool]] | None = None
    dr_states: pd.DataFrame | None = None
    dr_states_forward: pd.DataFrame | None = None
    decisions: RangeDecisions | None = None
    dr_jumps: pd.DataFrame | None = None


def _solve(
    pb: FilterProblem,
    params: FusionParams,
    discard: Callable[[pd.DataFrame], bool] | None,
    how: tuple[bool, bool, str],
    forward: bool,
) -> _Solved:
    """The forward pass, then the smoother and its robust refits (fuse's docstring;
    ``how``: smoothed_sigma, forward_sigma, dr_faults)."""
    smoothed_sigma, forward_sigma, faults = how
    window = params.dr_fault_window_s if params.state == "dr" and faults != "off" else 0.0
    rob = Robust(
        params.robust, params.k0, params.k1, params.mad_floor, params.mad_window, window,
        faults == "apply",
    )  # fmt: skip
    table, judged, filtered, checkpoints, gamma, found = _forward(pb, params, rob)
    jumps = jumps_table(pb.moving, pb.epochs, found)
    if faults == "apply":  # the smoother's re-runs and the refit take them (dr_faults.py)
        pb = dataclasses.replace(pb, proc=found)
    smooth = pb.block > 0
    if smooth and discard is not None and discard(table):
        if not pb.record_forward:  # the caller reads the table only: no trajectories
            return _Solved(table)
        smooth = False
        judged = None  # the caller reads the table only: no decisions kept
    if smooth:
        cp_x, cp_c = checkpoints
        refits = params.robust_smoother_iterations if params.state == "dr" and params.robust else 0
        # a smoother pass that a refit follows gives its states only: no variances, no DR
        # states (an n^2 product per reported value, ~1 s of 5 at 10 x 1 h)
        smoothed = mbf_backward(
            cp_x, cp_c, pb.nav, pb.proc, pb.kernel_obs, gamma, params.dims, pb.slots,
            pb.block, smoothed_sigma and refits == 0,
            dr_rec=pb.dr_rec if refits == 0 else pb.dr_rec[:0], reads=pb.reads,
        )  # fmt: skip
        spread = False
        # the pass before gave all this one would (no variances, no DR states asked)
        complete = not smoothed_sigma and pb.dr_rec.shape[0] == 0
        for _ in range(refits):
            # the robust factors against the smoothed solution, then the filter and the
            # smoother again with them (robust_refit.py); the forward trajectories stay
            # the causal filter's
            refit, resid_m, std_s = smoothed_gammas(
                pb.obs, pb.rec_ptr, pb.rec_plat, smoothed.xs, len(pb.moving), params.dims,
                gamma, params.k0, params.k1, params.mad_floor, pb.epochs,
            )  # fmt: skip
            # the last refit's decisions (a range without a smoothed residual keeps the
            # forward pass's factor, and its innovation)
            judged = _refit_judged(judged, resid_m[pb.obs["at"]], std_s[pb.obs["at"]])
            # the filter with the refit's factors: the checkpoints after the block of the
            # first changed factor (before it the filter is the same, bit for bit; none
            # changed on 2 of 9 refits of sample_logs, 14-40 % of the epochs precede it
            # on sample_logs and TIERS)
            first = _first_changed_block(gamma, refit, pb.obs["ptr"], pb.block, cp_x.shape[0])
            gamma = refit
            if pb.proc.jump_k.shape[0] and not spread:
                # the jumps the smoothed solution confirms, by its step, each spread over
                # the span before it was found (dr_faults.py); the filter changes from the
                # first jump's block, kept or not
                first = min(first, int(pb.proc.jump_k[0]) // pb.block)
                kept = confirmed_jumps(pb.proc, pb.epochs, pb.nav, pb.slots, smoothed.xs)
                pb = dataclasses.replace(pb, proc=spread_jumps(kept, pb.epochs, window))
                spread = True
            if first >= cp_x.shape[0] and complete:
                # no factor changed and no jump moved: the filter, the checkpoints and the
                # smoother would be the pass before's, bit for bit (20 of the 21 refits
                # of the observed fusion stage on `large` 10 x 1 h, the DR noise
                # cross-validation's)
                break
            # the last smoothed states go before the next pass takes as much again
            del smoothed, refit, resid_m, std_s
            refit_checkpoints(
                first, cp_x, cp_c, pb.nav, pb.proc, pb.kernel_obs, gamma, params.dims, pb.block,
                pb.reads,
            )  # fmt: skip
            smoothed = mbf_backward(
                cp_x, cp_c, pb.nav, pb.proc, pb.kernel_obs, gamma, params.dims, pb.slots,
                pb.block, smoothed_sigma, dr_rec=pb.dr_rec, reads=pb.reads,
            )  # fmt: skip
            complete = True
    else:
        smoothed = filtered
    at = pb.obs["at"]
    decisions = None
    if judged is not None:
        decisions = RangeDecisions(pb.source, judged[0], judged[1], gamma[at])
    active = pb.dr.active and pb.dr_states
    solutions = [(smoothed.xs, smoothed.var if smoothed_sigma else None, False)]
    if forward:
        solutions.insert(0, (filtered.xs, filtered.var if forward_sigma else None, True))
    return _Solved(
        table,
        solutions,
        _dr_table(pb, smoothed) if active else None,
        _dr_table(pb, filtered) if active else None,
        decisions,
        jumps,
    )


@gives_back  # the forward pass's working arrays, before the smoother's
def _forward(
    pb: FilterProblem, params: FusionParams, rob: Robust
) -> tuple[
    pd.DataFrame,
    tuple[FloatArray, FloatArray] | None,
    Smoothed,
    tuple[FloatArray, FloatArray],
    FloatArray,
    Process,
]:
    """The causal filter: the observations table, its decisions (the innovation at the
    prior and its standardized value), the forward states (as :class:`Smoothed`: states,
    variances, DR states), the smoother's checkpoints and the robust factors."""
    forward_slots = (
        pb.slots if pb.record_forward else Slots(np.zeros_like(pb.rec_ptr), pb.rec_plat[:0])
    )
    out = ekf_forward(
        pb.x0, pb.c0, pb.nav, pb.proc, pb.kernel_obs, params.dims, rob, forward_slots,
        pb.block, pb.dr_rec, np.zeros(0), pb.reads,
    )  # fmt: skip
    xs_f, var_f, gamma, innov, innov_var, cp_x, cp_c, dr_xf, dr_vf, std_innov = out[:10]
    jump_k, jump_p, jump_var = out[10:]
    at = pb.obs["at"]  # the range rows' observations, in row (= observation) order
    table = pd.DataFrame(
        {
            "time": pb.epochs[pb.ep_idx],
            "from": pb.from_id,
            "to": pb.to_id,
            "range": pb.obs["z"][at],
            "innovation": innov[at],
            "innovation_var": innov_var[at],
            "gamma": gamma[at],
        },
        copy=False,  # memory (issue 11): fresh arrays and immutable id columns, not copied
    )
    judged = (table["innovation"].to_numpy(), std_innov[at])
    proc = pb.proc._replace(jump_k=jump_k, jump_p=jump_p, jump_var=jump_var)
    return table, judged, Smoothed(xs_f, var_f, dr_xf, dr_vf), (cp_x, cp_c), gamma, proc


def _dr_table(pb: FilterProblem, states: Smoothed) -> pd.DataFrame:
    return dr_states_table(pb.moving, pb.epochs, pb.dr, (states.dr_xs, states.dr_var))


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
