"""The followers' dead-reckoning noise level: by leave-pair-out cross-validation, or by likelihood.

With DR states (``[fusion] state = "dr"``) the systematic part of a dead reckoning's
error (heading, heading rate, odometer scale) is in the state, and what the process noise
must cover is the rest: odometer noise, wheel slip, the heading noise of turns. How much
of it there is differs by an order of magnitude between platforms: the simulator's
pedestrians (0.005 m per sqrt(m)) against a ground robot on a plaza whose heading drifts
18 deg/min (``real/plaza2``). No one default suits both, so the level is estimated from
the data, as a batch factor graph's odometry sigmas would be by their evidence:

- one factor f scales every follower's DR noise 1-sigmas (the residual velocity noise,
  the distance and heading noise per metre, the heading, heading-rate and scale walks);
- for each f of a grid (:data:`GRID`: factors of 4 from 1/16 to 16, then factors of 2
  either side of the best), the forward filter runs once and the innovations of its
  ranges, one-step-ahead predictions each from the ranges before it only (the
  prediction-error decomposition of the likelihood: no range judges itself), score
  ``sum(log d + rho(v^2 / d))`` with d the innovation variance and rho Huber's loss at
  :data:`HUBER_K` (an NLOS run or a gross error adds linearly, not quadratically, so it
  cannot buy a looser dead reckoning by itself);
- the f of the lowest score is used (its figures scaled), with a note when it is not 1.

The NIS rounds of :mod:`~coopproc.stages.fusion.calibration` then run from there: they
inflate a platform whose innovations are still inconsistent. Every score is a sum over
ranges and compared between factors of one session, so a longer session of the same
quality picks the same factor (the grid is coarse: factors of 2).

That likelihood is fooled by range errors that last (an NLOS run, multipath along a
path): a looser dead reckoning lets the forward filter follow them, so the next
innovations shrink. On the simulator's ``paper-experiment`` it picks 4 x for the observed
ranges (mean follower error 0.215 m against 0.132 m at 1 x and 0.032 m at 1/16 x), on
TIERS, plaza2, tuc and MiLUV 16-32 x (TIERS tb4 0.18 -> 0.81 m). So it is off by default
(``dr_noise_search``), and the default search (:func:`dr_noise_cv`, ``[fusion] dr_noise_cv
= true``) judges a factor by **leave-pair-out cross-validation** instead:

- the pairs are split into :data:`CV_FOLDS` folds
  (:func:`~coopproc.stages.fusion.leave_out.pair_folds`); each fold's ranges are
  predicted by the smoothed fusion of all the other ranges with that factor;
- a fold's score is the MAD of each left-out pair's residuals about their median (a pair's
  own bias is not a dead-reckoning error); the factor's score is the median over pairs;
- the grid is :data:`CV_GRID` (1/16 to 1) and the best one's neighbours at half and
  twice, up to 1; of the factors within :data:`CV_TOLERANCE` of the best score, the one
  nearest 1 is taken.

The search only tightens. Loosening is what the NIS rounds of
:mod:`~coopproc.stages.fusion.calibration` do, per platform, when its innovations are
larger than predicted; what they cannot see is figures that are too loose, since the
range sigma dominates the innovation variance (median NIS ratio 0.4 on
``paper-experiment`` at every factor). Allowed to loosen too, the CV picked 4 x on
``dr-faults`` seed 0 (scores 0.240, 0.265, 0.199 m at 1, 2, 4 x: its wheel slips make
them noisy), and its A went from 0.21 to 0.30 m; on tuc 32 x (0.1569 against 0.1564 m).

A pair's lasting range error is its own, so a fusion without the pair cannot follow it,
whatever the factor; a dead-reckoning error is the platform's and shows in all its pairs,
and a factor too tight or too loose predicts every left-out pair worse. No range judges
itself, and the reference is never read. Measured (mean horizontal error of the
uncalibrated smoothed fusion at the factors of :data:`GRID`, and the CV's choice):
``paper-experiment`` seed 0 A/C 0.032/0.049, 0.047/0.061, 0.132/0.141, 0.216/0.216,
0.289/0.299 m, CV 1/32 (the refinement of 1/16); plaza2 0.911, 0.360, 0.215, 0.178,
0.257 m, CV 1 (the NIS rounds then inflate the robot's figures 3.3 x); TIERS (tb3-tb7) best
at 1, CV 1; MiLUV CV 1/4.

Only the first :data:`CV_EPOCHS` range epochs are fused (the answer for a session's first
hours does not change because the recording goes on). The CV fusions take the given
sigmas and the robust refit of ``robust_smoother_iterations`` (with the forward pass's
IGG-III factors alone the scores were not monotone on ``paper-experiment``). A session
with fewer than two pairs of :data:`CV_MIN_ROWS` ranges keeps 1. The factor is the
followers' (their dead reckoning's noise), so it is chosen once, on the observed ranges.

Which fusions take it: the observed ranges' fusion chooses it and every processed set
takes it; a smoothed set (DI-Based with ``[ranging.di] fusion_input = "distance"``, the
median baseline: :attr:`~coopproc.stages.base.RangeStage.smoothed`) kept the [fusion] figures until
2026-12-02 and still does with ``[fusion] dr_noise_cv_smoothed = false``
(docs/methods-fusion.md#di-dr-factor: on the figures the DI fusion followed the DI ranges'
lasting errors, 2.9 x observed-fused on ``paper-experiment`` seed 2 at 15 min). Why it
was kept apart first: a smoothed range is smoothed with the same dead reckoning, so its
errors are correlated with it and from epoch to epoch; fused with the tight factor, DI's own errors
show (``paper-experiment`` seed 2, C: DI-fused 0.048 m with the factor, 0.034 m with the
figures, against 0.038 m observed-fused), and a CV of its own for the DI ranges picks
1/16 (fooled by that correlation) with the same 0.048 m. Tried and not kept: the DI
fusion's own CV with the left-out pairs scored on their observed ranges (which the
smoothing did not touch): DI-fused went from 0.029 to 0.027 m on average over seeds 0-3
and ``noisy-leader`` (A and C), but on seed 2 it picked 1/4 and C's DI-fused error became
0.047 m, 1.23 x observed-fused.

Measured through ``coopproc run`` (mean horizontal error, followers A / C; before: the
[fusion] figures for every set): ``paper-experiment`` seed 0 (sample_logs) observed
0.132/0.140 -> 0.031/0.048 m (a GTSAM factor graph with evidence-tuned odometry:
0.077/0.094 m), RN 0.035/0.042 -> 0.024/0.035 m, DI 0.020/0.023 m unchanged; seed 2
observed 0.110/0.104 -> 0.040/0.038 m, RN 0.038/0.054 m, DI 0.032/0.034 m; the
``noisy-leader`` observed 0.033/0.048 m, RN 0.025/0.031 m, DI 0.024/0.024 m. With the
observed fusion this good, the observed fusion's robust refit rejects the simulated NLOS
ranges (0.6-0.8 m, sample_logs: 18 rejections, every one a true outlier) and RN's partial
corrections can make RN-fused worse than observed-fused (seed 2, C: 0.054 against
0.038 m: a corrected NLOS range is no longer rejected).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from coopproc.model import Session
from coopproc.stages.fusion.calibration_bias import pair_codes, residuals_by_row
from coopproc.stages.fusion.dr_states import dr_followers
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.fusion.inputs import FusionInputs, fusion_inputs
from coopproc.stages.fusion.leave_out import pair_folds

__all__ = [
    "CV_EPOCHS",
    "CV_FOLDS",
    "CV_GRID",
    "CV_MIN_ROWS",
    "CV_TOLERANCE",
    "GRID",
    "HUBER_K",
    "dr_noise_cv",
    "dr_noise_factor",
    "innovation_score",
]

#: The first factors tried (then the best one's neighbours at half and twice).
GRID = (1.0 / 16.0, 0.25, 1.0, 4.0, 16.0)
#: Huber's threshold on the standardized innovation (IGG-III's k0, paper 002 eq. (18)).
HUBER_K = 3.0
#: The cross-validation's first factors (then the best one's neighbours, up to 1): it
#: only tightens; a dead reckoning worse than its figures is the NIS rounds' to inflate.
CV_GRID = (1.0 / 16.0, 0.25, 1.0)
#: Folds of pairs of the cross-validation (each fold: one smoothed fusion per factor).
CV_FOLDS = 4
#: Range epochs, from the session's start, that the cross-validation fuses: on ``large``
#: (10 platforms, 45 pairs) 5,000 cost 2.5 s and 20,000 11.7 s, and its scores are within
#: 2 % of each other at every factor either way; TIERS picks 1 on its first 5,000 (of
#: 10,600) as on 20,000; sample_logs, plaza2, MiLUV and tuc have fewer.
CV_EPOCHS = 5_000
#: Ranges a pair needs to be left out and scored.
CV_MIN_ROWS = 20
#: Scores within this fraction of the best are a tie, won by the factor nearest 1: on
#: plaza2 the scores at 1 and 2 differ by 0.08 % (0.3659 / 0.3656 m), on paper-experiment
#: seed 0 those at 1/16 and 1/32 by 1.3 %, on tuc those at 16 and 32 by 2.7 % (chosen on
#: the three together, with TIERS, where 1 wins by 25 %).
CV_TOLERANCE = 0.01


def innovation_score(observations: pd.DataFrame) -> float:
    """The robust negative log-likelihood of a fusion's range innovations (module doc)."""
    v = observations["innovation"].to_numpy(np.float64)
    d = observations["innovation_var"].to_numpy(np.float64)
    good = np.isfinite(v) & np.isfinite(d) & (d > 0)
    v, d = v[good], d[good]
    s = np.abs(v) / np.sqrt(d)
    rho = np.where(s <= HUBER_K, s * s, 2.0 * HUBER_K * s - HUBER_K * HUBER_K)
    return float(np.sum(np.log(d) + rho))


def dr_noise_factor(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    inputs: FusionInputs,
    score: Callable[[pd.DataFrame], float] = innovation_score,
) -> tuple[float, dict[float, float]]:
    """The DR noise factor of the lowest innovation score, and every factor's score.

    1.0 (no search) when no platform carries DR states. Each trial is one forward pass
    (no smoother, no trajectories), on the prepared ``inputs``.
    """
    followers = dr_followers(session, inputs.moving, params)
    if not followers or not params.dr_noise_search:
        return 1.0, {}
    scores: dict[float, float] = {}

    def trial(factor: float) -> float:
        if factor not in scores:
            scale: Mapping[str, float] = dict.fromkeys(followers, factor)
            out = fuse(
                session, ranges, params, output="ranges", drift_scale=scale,
                discard=lambda table: True, inputs=inputs, forward=False, dr_faults="off",
            )  # fmt: skip
            scores[factor] = score(out.observations)
        return scores[factor]

    best = min(GRID, key=trial)
    for factor in (best / 2.0, best * 2.0):
        trial(factor)
    best = min(scores, key=lambda f: (scores[f], abs(np.log(f))))
    return best, dict(sorted(scores.items()))


def dr_noise_cv(
    session: Session, ranges: pd.DataFrame, params: FusionParams, moving: list[str]
) -> tuple[float, dict[float, float]]:
    """The followers' DR noise factor by leave-pair-out cross-validation (module doc), and
    every factor's score (the median over pairs of the left-out residuals' MAD, m).

    1.0 and no scores when no platform of ``moving`` carries DR states, the search is
    off (``dr_noise_cv``), or fewer than two pairs have :data:`CV_MIN_ROWS` ranges.
    """
    followers = dr_followers(session, moving, params)
    if not followers or not params.dr_noise_cv or len(ranges) == 0:
        return 1.0, {}
    times = ranges["time"].to_numpy(dtype=np.float64)
    unique = np.unique(times)
    if unique.shape[0] > CV_EPOCHS:
        ranges = ranges[times <= unique[CV_EPOCHS - 1]]
    codes = pair_codes(ranges["from"], ranges["to"])
    counts = np.bincount(codes.code.astype(np.int64), minlength=len(codes.names))
    eligible = [
        name for name, count in zip(codes.names, counts, strict=True) if count >= CV_MIN_ROWS
    ]
    if len(eligible) < 2:
        return 1.0, {}
    fold_of = pair_folds(eligible, CV_FOLDS)
    folds = []
    for k in sorted(set(fold_of.values())):
        codes_k = [codes.names.index(p) for p, f in fold_of.items() if f == k]
        held = np.isin(codes.code, codes_k)
        train = ranges[~held]
        test = ranges[held]
        inputs = fusion_inputs(session, train, params, "ranges")
        folds.append((train, test, codes.code[held], inputs))
    scores: dict[float, float] = {}

    def trial(factor: float) -> float:
        if factor in scores:
            return scores[factor]
        scale = dict.fromkeys(followers, factor)
        spread: list[float] = []
        for train, test, test_codes, inputs in folds:
            out = fuse(
                session, train, params, drift_scale=scale, smoothed_sigma=False,
                inputs=inputs, forward=False, dr_states=False, dr_faults="off",
            )  # fmt: skip
            resid = residuals_by_row(session, out, test)
            for code in np.unique(test_codes):
                r = resid[(test_codes == code) & np.isfinite(resid)]
                if r.shape[0] >= CV_MIN_ROWS:
                    spread.append(float(np.median(np.abs(r - np.median(r)))))
        scores[factor] = float(np.median(spread)) if spread else float("inf")
        return scores[factor]

    best = min(CV_GRID, key=lambda f: (trial(f), abs(np.log(f))))
    for factor in (best / 2.0, best * 2.0):
        if factor <= 1.0:
            trial(factor)
    low = min(scores.values())
    if not np.isfinite(low):
        return 1.0, {}
    # of the factors within CV_TOLERANCE of the best score, the one nearest 1
    near = [f for f, v in scores.items() if v <= low * (1.0 + CV_TOLERANCE)]
    return min(near, key=lambda f: (abs(np.log(f)), f)), dict(sorted(scores.items()))
