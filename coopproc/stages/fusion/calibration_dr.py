"""The followers' dead-reckoning noise level, chosen by the innovations' likelihood.

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
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from coopproc.model import Session
from coopproc.stages.fusion.dr_states import dr_followers
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.fusion.inputs import FusionInputs

__all__ = ["GRID", "HUBER_K", "dr_noise_factor", "innovation_score"]

#: The first factors tried (then the best one's neighbours at half and twice).
GRID = (1.0 / 16.0, 0.25, 1.0, 4.0, 16.0)
#: Huber's threshold on the standardized innovation (IGG-III's k0, paper 002 eq. (18)).
HUBER_K = 3.0


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
                discard=lambda table: True, inputs=inputs, forward=False,
            )  # fmt: skip
            scores[factor] = score(out.observations)
        return scores[factor]

    best = min(GRID, key=trial)
    for factor in (best / 2.0, best * 2.0):
        trial(factor)
    best = min(scores, key=lambda f: (scores[f], abs(np.log(f))))
    return best, dict(sorted(scores.items()))
