"""Which range epochs the platform range-bias iteration of a long session fuses.

The self-calibration (:mod:`coopproc.stages.fusion.calibration`) estimates a platform's
range bias by iteration: up to 9 whole fusions (:func:`~.calibration_bias.platform_bias`).
On a day of 10 platforms (3.8 M range epochs) each costs about a minute. The bias is the
fixed point where the platform's median post-fit residual is zero, a statistic of the
whole session that a large, spread sample gives as well, so above
:data:`CALIBRATION_EPOCHS` distinct range times the iteration fuses only
:data:`CALIBRATION_EPOCHS` of them, thinned evenly over the whole session: range epoch i
(in time order) is kept when frac(i phi) < cap / n, phi the golden ratio. The bias then
takes one step on every range (a thinned fusion absorbs a little more of a bias), and the
fusion returned fuses every range with it.

- Thinned, not blocks: every stretch of the session keeps the same fraction of its
  epochs, so the filter never bridges a long gap. Blocks of consecutive epochs with gaps
  between them (10 blocks of 444 s over 4 h) were measured and rejected: across a gap
  of an hour the dead reckoning drifts by meters, the filter restarts from a covariance
  of ~10 m and some pairs' solutions did not recover (calibrated pair sigma up to 26 m,
  two drifts inflated, every follower's horizontal RMSE ~60 % worse on 10 x 4 h).
- The golden-ratio sequence (a Weyl sequence), not every k-th epoch: with staggered
  polling, epoch i is pair i mod P, and keeping every k-th epoch would keep only
  P / gcd(k, P) of the pairs; frac(i phi) is equidistributed along every such residue
  class, so each pair keeps its share at any k.

- The drift rounds (a median NIS per platform) are not thinned: a dead reckoning worse
  than declared gives innovations that grow faster with the interval between a
  platform's ranges than the predicted variance does, so on a thinned subset its NIS,
  and the drift inflation, come out larger (dr-faults seed 0-2, 1 in 20 epochs kept: the
  followers' drift scales 1.6-3.5 became 2.9-8.6, mean horizontal RMSE +47 % / -45 % /
  +9 %). They are forward-only fusions already (the smoother only for the last).

At or below the cap, nothing changes: the iteration fuses every range, as before.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = ["CALIBRATION_EPOCHS", "calibration_rows"]

#: Distinct range times above which the bias iteration fuses a subset.
CALIBRATION_EPOCHS = 200_000
#: The golden ratio's fractional part: the step of the thinning sequence.
_GOLDEN = 0.6180339887498949


def calibration_rows(
    times: FloatArray, cap: int | None = CALIBRATION_EPOCHS
) -> NDArray[np.intp] | None:
    """Row positions (ascending) of the ranges the bias iteration fuses, or None for all.

    ``times``: each range's time. None when the session has ``cap`` distinct times or
    fewer (or ``cap`` is None). Otherwise the rows of at most ``cap`` distinct times: the
    i-th distinct time (ascending) is kept when frac(i phi) < cap / n (n distinct
    times), rows at one time kept or dropped together. Deterministic: it depends on the
    distinct times only (not on the row order).
    """
    if cap is None:
        return None
    if cap < 1:
        raise ValueError(f"calibration subset: cap {cap} must be >= 1")
    unique, epoch = np.unique(np.asarray(times, dtype=np.float64), return_inverse=True)
    n = int(unique.shape[0])
    if n <= cap:
        return None
    keep = (np.arange(n, dtype=np.float64) * _GOLDEN) % 1.0 < cap / n
    keep[np.flatnonzero(keep)[cap:]] = False  # the sequence's discrepancy: a few too many
    return np.flatnonzero(keep[epoch.ravel()])
