"""The cooperative fusion as the chain sees it: registry entry ``fusion``.

The centralized cooperative EKF with IGG-III and RTS smoothing, self-calibrated
(:func:`coopproc.stages.fusion.calibration.calibrated_fuse`), run once per range set; its
positions.csv method is the range set's name (DATA.md: ``observed``, ``rn``, ``di``). The
processed sets take the observed fusion's per-pair sigmas as floor. On the observed ranges
it also gives the cooperative solution the ranging stage needs. A processed set that holds
the observed ranges (the range processing changed none: same
:func:`~coopproc.stages.fusion.range_digest.range_rows_digest`) gets the observed fusion's
solution instead of a second, identical fusion. Its IGG-III factor per range goes to
range_weights.csv (:mod:`~coopproc.stages.fusion.range_weights`). Every
processed set takes the observed fusion's DR noise factor (``dr_noise_cv``; a smoothed
set, DI, unless ``dr_noise_cv_smoothed = false``); with ``[fusion] carry_weights`` a
smoothed set (DI) also carries the observed fusion's judgement of each of its ranges
(:mod:`~coopproc.stages.fusion.carried_weights`).

The fusion needs every moving platform's navigation and never sees a tag; the UWB-only
methods that position one are in :mod:`coopproc.stages.anchors.entry`.
"""

from __future__ import annotations

import dataclasses

from coopproc.model import Session
from coopproc.stages.base import PositionInput, PositionProduct, PositionStage
from coopproc.stages.fusion.calibration import FusionCalibration, calibrated_fuse
from coopproc.stages.fusion.carried_weights import carried_factors
from coopproc.stages.fusion.dr_faults import jumps_of
from coopproc.stages.fusion.fuse import FusionOutput, FusionParams
from coopproc.stages.fusion.leave_out import leave_pair_out
from coopproc.stages.fusion.range_digest import range_rows_digest
from coopproc.stages.fusion.range_weights import range_weights_frame
from coopproc.stages.shared.data import range_sigma_default, shared_nav
from coopproc.stages.shared.dr_corrected import corrected_by_others

__all__ = ["FUSION", "fusion_stage"]


def fusion_stage(inp: PositionInput, params: FusionParams) -> PositionProduct:
    """Fuse one range set (see the module docstring)."""
    floor = None
    dr_factor = None  # the DR noise factor: chosen here (observed ranges) or the figures'
    observed_cal = inp.observed.calibration if inp.observed is not None else None
    if isinstance(observed_cal, FusionCalibration):
        floor = observed_cal.pair_sigma_m
        if params.dr_noise_cv:  # the observed ranges' factor, smoothed ranges' too
            # (docs/methods-fusion.md#dr-noise-cv: on the figures, paper-experiment seed 2
            # at 15 min had DI-fused 2.9 x observed-fused, MiLUV 1.24 x)
            keep = inp.smoothed and not params.dr_noise_cv_smoothed
            dr_factor = 1.0 if keep else observed_cal.dr_noise_factor
    digest = range_rows_digest(
        inp.session, inp.ranges, range_sigma_default(inp.session, params.range_sigma_m)
    )
    if (
        inp.observed is not None
        and isinstance(observed_cal, FusionCalibration)
        and observed_cal.range_digest == digest
        and not inp.want_cp
    ):
        return _same_as_observed(inp, inp.observed, observed_cal)
    carried = None  # the observed fusion's decisions on a smoothed set (carried_weights.py)
    if (
        params.carry_weights
        and params.robust
        and inp.smoothed
        and inp.observed is not None
        and inp.observed.range_weights is not None
    ):
        carried = carried_factors(
            inp.session, inp.ranges, inp.observed.range_weights, params.k0, params.k1
        )
    with shared_nav():  # the calibration's fusions of this range set: the same epochs
        fused, cal = calibrated_fuse(
            inp.session,
            inp.ranges,
            params,
            output=inp.output,
            label=inp.range_set,
            sigma_floor=floor,
            smoothed_sigma=False,  # positions.csv and the ranging stage take positions only
            # the forward solution is the CP solution's increments only (memory, issue 11)
            forward=inp.want_cp and inp.output == "ranges" and _cp_is_main(params),
            forward_sigma=False,  # the ranging stage reads the CP solution's positions
            dr_factor=dr_factor,
            row_factor=carried,
        )
        cp = None
        cp_session = inp.session
        if inp.want_cp:
            at_ranges, cp_cal, cp_session = _cp_solution(inp, params, fused, cal)
            cp = (at_ranges.forward, at_ranges.smoothed)
    left_out = None
    if inp.want_cp:  # each pair's CP DI without its own ranges (leave_out.py, issue 30)
        left_out = leave_pair_out(
            cp_session, inp.ranges, params, cp_cal.pair_sigma_m, cp_cal.drift_scale,
            cp_cal.platform_bias_m,
        )  # fmt: skip
    cal = dataclasses.replace(cal, range_digest=digest, dr_jumps=jumps_of(fused.dr_jumps))
    return PositionProduct(
        positions=fused.smoothed,
        cp=cp,
        cp_left_out=left_out,
        calibration=cal,
        notes=cal.notes,
        dr_states=fused.dr_states,
        dr_states_forward=fused.dr_states_forward,
        range_weights=range_weights_frame(inp.ranges, fused),
    )


def _cp_params(params: FusionParams) -> FusionParams:
    """The parameters of the fusion that gives the ranging stage's cooperative solution:
    the position state unless ``cp_state = "dr"``."""
    state = "dr" if params.cp_mode == "dr" else "position"
    return dataclasses.replace(params, state=state, cp_state="position")


def _cp_is_main(params: FusionParams) -> bool:
    """True when the range set's own fusion is the CP solution's (the same state; the
    corrected solution fuses other navigation)."""
    mode = params.cp_mode
    return mode != "corrected" and (mode == "dr") == (params.state == "dr")


def _cp_solution(
    inp: PositionInput, params: FusionParams, fused: FusionOutput, cal: FusionCalibration
) -> tuple[FusionOutput, FusionCalibration, Session]:
    """The ranging stage's cooperative solution (``[fusion] cp_state``), its calibration and
    the session it was fused from.

    ``corrected`` (the default, ``auto``, with DR states): paper 000's fusion (position
    state) of the followers' navigation corrected by the range set's causal DR states
    (heading and scale, :mod:`~coopproc.stages.shared.dr_corrected`): on long recordings
    the followers' heading error makes the position-state fusion of the navigation as
    recorded diverge, and on `large` at 1 h its errors reach DI-fused through the DI
    (docs/methods-ranging.md#cp-state). ``position`` (``auto`` with the position state):
    that fusion of the navigation as recorded, paper 000's own input. With the DR states'
    forward solution itself (``dr``) DI flags 22 % of TIERS tb3-tb4's clean epochs (0-5 %
    with the position-state fusion; docs/methods-fusion.md).
    """
    if inp.output == "ranges" and _cp_is_main(params):
        return fused, cal, inp.session
    session = inp.session
    if params.cp_mode == "corrected" and fused.dr_states_forward is not None:
        # a follower with one partner keeps its own navigation: its states are fitted to
        # that pair's ranges alone (dr_corrected.judged_by_others)
        session = corrected_by_others(inp.session, fused.dr_states_forward)
    at_ranges, cp_cal = calibrated_fuse(
        session, inp.ranges, _cp_params(params), output="ranges", smoothed_sigma=False
    )
    return at_ranges, cp_cal, session


def _same_as_observed(
    inp: PositionInput, observed: PositionProduct, cal: FusionCalibration
) -> PositionProduct:
    """The observed fusion's product for a range set holding the same ranges
    (:mod:`~coopproc.stages.fusion.range_digest`): the same self-calibration (its floor,
    the observed sigmas, is what it computes), so the same solution; its notes named for
    this range set, and one saying so."""
    mine = f"fusion ({inp.range_set}): "
    notes = tuple(
        mine + note.removeprefix("fusion (observed): ")
        for note in cal.notes
        if note.startswith("fusion (observed): ")
    )
    notes += (
        f"{mine}the {inp.range_set} ranges are the observed ones (the range processing "
        "changed none): its fusion is the observed fusion, reused, not run again",
    )
    return PositionProduct(
        positions=dict(observed.positions),  # the same trajectories, in a dict of its own
        calibration=dataclasses.replace(cal, notes=notes),
        notes=notes,
        dr_states=observed.dr_states,
        range_weights=observed.range_weights,  # the same fusion's decisions
    )


FUSION = PositionStage(
    name="fusion",
    params_type=FusionParams,
    section="fusion",
    run=fusion_stage,
    help="cooperative EKF + IGG-III + RTS smoother over all platforms (papers 002, 003), "
    "once per range set; method = the range set's name",
    named_by_range_set=True,
    provides_cp=True,
    needs_observed=True,
)
