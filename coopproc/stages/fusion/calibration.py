"""Self-calibrated cooperative fusion: ranging noise per pair and dead-reckoning consistency.

:func:`fuse` weighs each range with one declared sigma and each platform's dead reckoning
with one declared drift. Real sessions break both: some pairs are body-blocked for minutes
(TIERS: every pair with tb4 reads 0.1-0.7 m long for most of the run), and declared drifts
are often optimistic (the dr-faults scenario: a 3 deg/min heading drift). So
:func:`calibrated_fuse`:

1. fuses with the given sigmas and drifts; the normalized innovation squared (NIS,
   v^2 / (H C H^T + R) at the prior) of every range tells, per platform, whether its dead
   reckoning drifts more than declared: the median NIS over the ranges it takes part in,
   divided by the median of chi^2(1) (0.455), is ~1 when consistent. A platform above
   :data:`NIS_LIMIT` has its drift sigma scaled by sqrt(NIS), and the fusion is repeated
   until none is (at most :data:`NIS_ROUNDS` rounds; a note names the platform). A
   leader is never inflated: its own fix observes its position every epoch, so the
   ranges' inconsistency is its partners' drift;
2. takes each pair's ranging error from the post-fit residuals ``L - ||X_a - X_b||`` of
   that solution: the RMS (bias included: a pair whose ranges are persistently long cannot
   be explained by any position, and must pull less) after dropping gross errors beyond 5
   MAD, combined with the declared sigma as a prior
   (:func:`~coopproc.estimation.sigma_prior.posterior_sigma`), and never below the declared
   sigma (inflate only) nor below ``sigma_floor``;
3. when one platform's pairs are all worse than the others' and its ranges' median
   residual differs from the others' by a bias that matters (a fraction of its ranging
   sigma, :func:`~.calibration_bias.biased_platform`), estimates a constant range bias of
   that platform by iteration and corrects its ranges, if that cuts the platform's
   residual RMS by 10 % (:func:`~.calibration_bias.platform_bias`; a note says so),
   then re-checks that platform's drift;
4. fuses with those sigmas, corrections and drifts (or keeps the first fusion when nothing
   changed).

Every test is on an effect size (a median NIS ratio, an RMS ratio, a bias against the
ranging sigma), none on a significance that grows with the number of ranges, so a longer
session of the same quality calibrates the same way. Above
:data:`~coopproc.stages.fusion.calibration_subset.CALIBRATION_EPOCHS` range epochs, the
bias iteration of step 3 (up to 9 whole fusions) fuses an evenly thinned subset of the
ranges (:func:`~coopproc.stages.fusion.calibration_subset.calibration_rows`); steps 1, 2
and 4 fuse every range (the drift NIS depends on the interval between a platform's
ranges, so drift rounds on a thinned subset inflate more: measured, not adopted).

Each pair's median post-fit residual is reported as its bias, not removed: a fit absorbs
part of it, and biases of several pairs trade off against the positions.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.estimation.robust import MAD_SCALE
from coopproc.estimation.sigma_prior import posterior_sigma
from coopproc.model import FloatArray, Session
from coopproc.stages.fusion.calibration_bias import (
    PairCodes,
    bias_words,
    biased_platform,
    code_groups,
    pair_codes,
    platform_bias,
    postfit_residuals,
    residuals_by_row,
)
from coopproc.stages.fusion.calibration_dr import dr_noise_cv, dr_noise_factor
from coopproc.stages.fusion.calibration_subset import CALIBRATION_EPOCHS, calibration_rows
from coopproc.stages.fusion.dr_states import dr_followers
from coopproc.stages.fusion.fuse import FusionOutput, FusionParams, fuse
from coopproc.stages.fusion.inputs import FusionInputs, fusion_inputs

__all__ = ["FusionCalibration", "calibrated_fuse", "postfit_residuals"]

#: Median NIS / median chi^2(1) above which a platform's dead reckoning is inflated.
NIS_LIMIT = 2.0
#: The same for a follower with DR states (``[fusion] state = "dr"``): its model carries
#: the systematic DR errors, so its innovations should be consistent (median NIS ratio
#: ~1; measured 0.4-0.85 on the simulator and TIERS, 1.54 on plaza2 whose heading rate
#: wanders): a smaller excess already says its noise figures are too small.
NIS_LIMIT_DR = 1.3
#: Rounds of drift inflation at most.
NIS_ROUNDS = 5
#: Median of the chi-square distribution with one degree of freedom.
CHI2_1_MEDIAN = 0.4549
#: Gross errors dropped from the per-pair RMS: beyond this many MADs from the median.
GROSS_MADS = 5.0
#: Fewer residuals than this: the pair keeps its given sigma.
MIN_RESIDUALS = 20


@dataclass(frozen=True)
class FusionCalibration:
    """What the self-calibration of one fusion estimated and applied."""

    pair_sigma_m: Mapping[str, float]  # the ranging 1-sigma used per pair
    pair_rms_m: Mapping[str, float]  # post-fit residual RMS per pair (gross errors out)
    pair_bias_m: Mapping[str, float]  # median post-fit residual per pair (reported only)
    platform_nis: Mapping[str, float]  # median NIS / 0.455 of each platform's ranges
    drift_scale: Mapping[str, float]  # factor applied to a platform's drift sigma
    notes: tuple[str, ...] = field(default=())
    #: the followers' DR noise factor chosen by the innovations' likelihood (state "dr",
    #: :mod:`~coopproc.stages.fusion.calibration_dr`; in ``drift_scale`` too) and the
    #: score of every factor tried
    dr_noise_factor: float = 1.0
    dr_noise_scores: Mapping[float, float] = field(default_factory=dict)
    #: :func:`~coopproc.stages.fusion.range_digest.range_rows_digest` of the ranges fused
    #: ("" when not taken): a range set with the same digest has this fusion
    range_digest: str = ""
    #: platform -> the range bias corrected in the fusion (m; the biased platforms only)
    platform_bias_m: Mapping[str, float] = field(default_factory=dict)
    #: the dead-reckoning jumps the fusion's forward filter found: (platform, time, size
    #: in m) in time order (:mod:`~coopproc.stages.fusion.dr_faults`)
    dr_jumps: tuple[tuple[str, float, float], ...] = ()


def _pair_figures(
    resid: FloatArray, pairs: PairCodes
) -> tuple[dict[str, float], dict[str, float], dict[str, int]]:
    """RMS, median and count of each pair's finite residuals (``resid`` per row of
    ``pairs``), pairs in name order."""
    rms: dict[str, float] = {}
    bias: dict[str, float] = {}
    count: dict[str, int] = {}
    for code, sel in code_groups(pairs.code, len(pairs.names)):
        pair = pairs.names[code]
        r = resid[sel]
        r = r[np.isfinite(r)]
        if r.shape[0] < MIN_RESIDUALS:
            continue
        med = float(np.median(r))
        mad = MAD_SCALE * float(np.median(np.abs(r - med)))
        kept = r[np.abs(r - med) <= GROSS_MADS * mad] if mad > 0 else r
        rms[pair] = float(np.sqrt(np.mean(kept * kept)))
        bias[pair] = med
        count[pair] = int(kept.shape[0])
    return rms, bias, count


def _platform_nis(observations: pd.DataFrame) -> dict[str, float]:
    """Median NIS / :data:`CHI2_1_MEDIAN` of each platform's ranges (as from or to),
    platforms in name order; grouped by integer platform codes."""
    nis = observations["innovation"].to_numpy() ** 2 / observations["innovation_var"].to_numpy()
    nis = np.asarray(nis, dtype=np.float64)
    out: dict[str, float] = {}
    code_from, names_from = pd.factorize(observations["from"])  # missing id: -1, no group
    code_to, names_to = pd.factorize(observations["to"])
    names = sorted({str(n) for n in names_from} | {str(n) for n in names_to})
    rank = {name: i for i, name in enumerate(names)}
    codes = np.concatenate(
        [
            np.append([rank[str(n)] for n in names_from], -1).astype(
                np.int16 if len(names) < 2**15 else np.int64
            )[code_from],
            np.append([rank[str(n)] for n in names_to], -1).astype(
                np.int16 if len(names) < 2**15 else np.int64
            )[code_to],
        ]
    )
    both = np.concatenate([nis, nis])
    keep = codes >= 0
    if not keep.all():
        codes, both = codes[keep], both[keep]
    for code, sel in code_groups(codes, len(names)):
        platform = names[code]
        values = both[sel]
        values = values[np.isfinite(values)]
        if values.shape[0] >= MIN_RESIDUALS:
            out[platform] = float(np.median(values)) / CHI2_1_MEDIAN
    return out


def _drift_scales(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    scale: dict[str, float],
    only: set[str] | None = None,
    smoothed_sigma: bool = True,
    smoothed: bool = True,
    inputs: FusionInputs | None = None,
    forward: bool = True,
    forward_sigma: bool = True,
) -> tuple[FusionOutput, dict[str, float], dict[str, float]]:
    """Inflate the drift of platforms whose range innovations are inconsistent (NIS above
    :data:`NIS_LIMIT`) by sqrt(NIS), refusing until none is (at most
    :data:`NIS_ROUNDS` rounds). ``only``: the platforms that may be inflated.
    Returns the last fusion (at the range epochs), the scales and the last NIS.
    ``smoothed=False``: the caller reads only the scales (every fusion forward only).
    ``inputs``: :func:`fusion_inputs` of ``ranges`` at the range epochs (None: prepared
    here), shared by every round (they differ only in the drift scales). ``forward``:
    build the forward trajectories (``forward_sigma``: with sigmas; :func:`fuse`)."""
    if inputs is None:
        inputs = fusion_inputs(session, ranges, params, "ranges")
    moving = set(session.moving_platforms()) if only is None else only
    # a leader's own fix observes its position every epoch: a range inconsistent with it
    # says that the other end drifts (dr-faults: the leader B "drifted more than declared,
    # x2.1" with its partners, its own figures 0.0001 m/s against 0.0087; leaving it out
    # changes the fused means by under 1 mm there)
    moving = {p for p in moving if session.platforms[p].role != "leader"}
    limit = dict.fromkeys(dr_followers(session, inputs.moving, params), NIS_LIMIT_DR)
    scale = dict(scale)
    last: list[tuple[pd.DataFrame, dict[str, float]]] = []

    def platform_nis(observations: pd.DataFrame) -> dict[str, float]:
        # a fusion's table is read by refitted() and then here: its NIS once
        if not last or last[0][0] is not observations:
            last[:] = [(observations, _platform_nis(observations))]
        return last[0][1]

    def high_nis(nis: Mapping[str, float]) -> dict[str, float]:
        return {p: v for p, v in nis.items() if p in moving and v > limit.get(p, NIS_LIMIT)}

    def refitted(observations: pd.DataFrame) -> bool:
        # a fusion whose NIS calls for another round is read for its innovations only:
        # its smoother pass would be thrown away (fusion 0..NIS_ROUNDS-1 may be refitted)
        if not smoothed:
            return True
        return fits < NIS_ROUNDS and bool(high_nis(platform_nis(observations)))

    fits = 0
    fused = fuse(
        session, ranges, params, output="ranges", drift_scale=scale,
        smoothed_sigma=smoothed_sigma, discard=refitted, inputs=inputs, forward=forward,
        forward_sigma=forward_sigma, dr_faults="judge",
    )  # fmt: skip
    nis = platform_nis(fused.observations)
    for done in range(NIS_ROUNDS):
        high = high_nis(nis)
        if not high:
            break
        for platform, value in high.items():
            scale[platform] = scale.get(platform, 1.0) * float(np.sqrt(value))
        fits = done + 1
        del fused  # the refit's arrays take its place, not beside it
        last.clear()
        fused = fuse(
            session, ranges, params, output="ranges", drift_scale=scale,
            smoothed_sigma=smoothed_sigma, discard=refitted, inputs=inputs, forward=forward,
            forward_sigma=forward_sigma, dr_faults="judge",
        )  # fmt: skip
        nis = platform_nis(fused.observations)
    return fused, scale, nis


def calibrated_fuse(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    *,
    output: Literal["ranges", "nav"] = "ranges",
    label: str = "observed",
    sigma_floor: Mapping[str, float] | None = None,
    smoothed_sigma: bool = True,
    max_epochs: int | None = CALIBRATION_EPOCHS,
    forward: bool = True,
    forward_sigma: bool = True,
    dr_factor: float | None = None,
    row_factor: FloatArray | None = None,
) -> tuple[FusionOutput, FusionCalibration]:
    """Fuse with per-pair sigmas and drift scales estimated from the data (module docstring).

    ``ranges``: columns time, from, to, range, sigma (the given sigma per row, the prior).
    ``label`` names the range set in notes. ``sigma_floor``: per pair, the smallest sigma
    to use. Processed (smoothed) ranges get the observed ranges' calibrated sigmas as
    floor: their post-fit residuals are small, but their errors are correlated over many
    epochs, so weighting them by that RMS as if white makes the fusion overconfident
    (measured on paper-experiment seed 1: fused DI mean error 0.080 m against 0.074 m).
    ``max_epochs``: above this many distinct range times the platform range-bias
    iteration fuses an evenly thinned subset (:func:`calibration_rows`; None: always
    every range). ``forward``: the result's forward trajectories are built (False: the
    smoothed only, :func:`fuse`); ``forward_sigma``: with their sigmas. ``dr_factor``:
    the followers' DR noise factor, chosen already (the observed ranges' cross-validation,
    for a processed range set); None: chosen here (:mod:`.calibration_dr`).
    ``row_factor``: per row, a weight in (0, 1] carried from another fusion
    (:mod:`~.carried_weights`): every fusion here takes the row's sigma over its square
    root, after the per-pair sigmas; the pair figures are of the unweighted sigmas.
    """
    default = session.config.uwb_sigma_m or params.range_sigma_m
    given = pd.to_numeric(ranges["sigma"], errors="coerce").to_numpy(dtype=np.float64)
    given = np.where(np.isfinite(given) & (given > 0), given, default)
    inflate = None if row_factor is None else 1.0 / np.sqrt(row_factor)
    unweighted = ranges
    if inflate is not None:
        ranges = ranges.assign(sigma=given * inflate)
    if not params.self_calibrate:
        plain = fuse(
            session, ranges, params, output=output, smoothed_sigma=smoothed_sigma,
            forward=forward, forward_sigma=forward_sigma,
        )  # fmt: skip
        return plain, FusionCalibration({}, {}, {}, {}, {})
    # 1. dead reckoning that the ranges contradict, with the given range sigmas; what the
    # fusions of this range set share is prepared once (fusion_inputs)
    inputs = fusion_inputs(session, ranges, params, "ranges")
    # 0. the followers' DR noise level (state "dr"): by leave-pair-out cross-validation
    # (default), or by the innovations' likelihood (dr_noise_search), or given
    dr_scores: dict[float, float] = {}
    how = "given"
    if dr_factor is None and params.dr_noise_search:
        dr_factor, dr_scores = dr_noise_factor(session, ranges, params, inputs)
        how = "the factor of the most likely range innovations"
    elif dr_factor is None:
        dr_factor, dr_scores = dr_noise_cv(session, ranges, params, inputs.moving)
        how = "the factor whose fusions best predict the ranges of pairs left out of them"
    elif dr_factor != 1.0:
        how = "the factor the observed ranges' cross-validation chose"
    with_dr = set(dr_followers(session, inputs.moving, params))
    start = dict.fromkeys(sorted(with_dr), dr_factor) if dr_factor != 1.0 else {}
    first, scale, first_nis = _drift_scales(
        session, ranges, params, start, smoothed_sigma=smoothed_sigma, inputs=inputs,
        forward=forward, forward_sigma=forward_sigma,
    )  # fmt: skip
    # 2. per-pair ranging sigma from the post-fit residuals
    pairs = pair_codes(ranges["from"], ranges["to"])
    resid = residuals_by_row(session, first, ranges)
    rms, bias, count = _pair_figures(resid, pairs)
    sigma_used: dict[str, float] = {}
    notes: list[str] = []
    new_sigma = given.copy()
    for code, sel in code_groups(pairs.code, len(pairs.names)):
        pair = pairs.names[code]
        prior = float(np.median(given[sel]))
        if pair in rms:
            # inflate only: a declared sigma above the post-fit RMS stays (shrinking it
            # lets the correlated dead-reckoning and NLOS errors through: paper-experiment
            # seed 3, fused A 0.151 m against 0.134 m with the declared 0.15 m)
            sigma_used[pair] = max(prior, posterior_sigma(prior, rms[pair], count[pair]))
        else:
            sigma_used[pair] = prior
        if sigma_floor is not None and pair in sigma_floor:
            sigma_used[pair] = max(sigma_used[pair], sigma_floor[pair])
        new_sigma[sel] = sigma_used[pair]
    calibrated = ranges.assign(sigma=new_sigma if inflate is None else new_sigma * inflate)
    # 3. a platform whose ranges all disagree, by a bias that matters: its range bias,
    # then its drift afresh; the bias iteration on a thinned subset of a long session
    platform_factor = biased_platform(sigma_used, resid, unweighted, given)
    if platform_factor:
        unscaled = {p: v for p, v in scale.items() if p not in platform_factor}
        unscaled |= {p: v for p, v in start.items() if p in platform_factor}
        rows = calibration_rows(ranges["time"].to_numpy(dtype=np.float64), max_epochs)
        calibrated, found = platform_bias(session, calibrated, params, platform_factor, rows)
        platform_factor = {p: f for p, f in platform_factor.items() if p in found}
        for platform, factor in sorted(platform_factor.items()):
            notes.append(
                f"fusion ({label}): the ranges of {platform} disagree with the rest of the "
                f"network (its pairs' sigma {factor:.1f} x the others') and read "
                f"{bias_words(found[platform])} on average (body shadowing or an "
                "antenna delay): corrected by that in the fusion"
            )
        if platform_factor:
            inputs = inputs.with_ranges(calibrated)  # the corrected ranges and new sigmas
            _, scale, _ = _drift_scales(
                session, calibrated, params, unscaled, only=set(platform_factor),
                smoothed_sigma=False, smoothed=False, inputs=inputs, forward=False,
            )  # fmt: skip
    unchanged = np.array_equal(new_sigma, given) and not platform_factor
    # the calibration's fusions only look for the dead reckoning's jumps (dr_faults.py):
    # the fusion returned gives them (one more fusion when the first found some)
    jumped = first.dr_jumps is not None and len(first.dr_jumps) > 0
    if unchanged and output == "ranges" and not jumped:
        result, nis = first, first_nis  # the sigmas, biases and drifts of the first fusion stand
    else:
        del first, resid  # freed before the final fusion, not held beside it
        # the same rows, epochs and observation structure: new sigmas (and range values)
        final = inputs.with_ranges(calibrated, output)
        del inputs  # the first inputs' var and z arrays, not held beside the final ones
        result = fuse(
            session, calibrated, params, output=output, drift_scale=scale,
            smoothed_sigma=smoothed_sigma, inputs=final, forward=forward,
            forward_sigma=forward_sigma,
        )  # fmt: skip
        del final
        nis = _platform_nis(result.observations)
    if dr_factor != 1.0:
        notes.append(
            f"fusion ({label}): the followers' dead-reckoning noise is {dr_factor:g} x the "
            f"[fusion] figures ({how})"
        )
    for platform, total in sorted(scale.items()):
        factor = total / start.get(platform, 1.0)  # the NIS rounds' part
        if factor == 1.0:
            continue
        what = (
            "its dead-reckoning noise figures (the residual velocity and distance noise, the "
            "heading, heading-rate and scale walks) are"
            if platform in with_dr
            else "its drift sigma is"
        )
        notes.append(
            f"fusion ({label}): {platform}'s dead reckoning drifts more than declared (its "
            f"range innovations were inconsistent); {what} scaled by {factor:.1f}"
        )
    return result, FusionCalibration(
        pair_sigma_m=sigma_used,
        pair_rms_m=rms,
        pair_bias_m=bias,
        platform_nis=nis,
        drift_scale=scale,
        notes=tuple(notes),
        dr_noise_factor=dr_factor,
        dr_noise_scores=dr_scores,
        platform_bias_m={p: found[p] for p in platform_factor} if platform_factor else {},
    )
