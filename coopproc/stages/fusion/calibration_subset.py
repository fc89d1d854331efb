"""Which range epochs the self-calibration rounds of a long session fuse.

The self-calibration (:mod:`coopproc.stages.fusion.calibration`) fuses a session several
times (drift rounds, the platform range-bias iteration) before the fusion it returns. On a
day of 10 platforms (3.8 M range epochs) each of those fusions costs about a minute. The
quantities they estimate (a median NIS per platform, a post-fit RMS per pair, a platform's
median residual) are statistics of the whole session that a large, spread sample gives
as well, so above :data:`CALIBRATION_EPOCHS` distinct range times the rounds fuse only
:data:`CALIBRATION_BLOCKS` blocks of consecutive range epochs, of equal count, spread
evenly from the first epoch to the last (the first block starts at the session's start,
the last one ends at its end), :data:`CALIBRATION_EPOCHS` epochs in all. The fusion
returned is then one fusion of every range with the calibrated values.

Blocks rather than every k-th epoch: inside a block the filter sees the ranges at their
recorded rate, so the innovations, the NIS and the post-fit residuals have the same
statistics as in the whole session; between blocks the fusion bridges the gap with dead
reckoning and its process noise, as over any range outage.

At or below the cap, nothing changes: every round fuses every range, as before.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = ["CALIBRATION_BLOCKS", "CALIBRATION_EPOCHS", "calibration_rows"]

#: Distinct range times above which the calibration rounds fuse a subset.
CALIBRATION_EPOCHS = 200_000
#: The subset's blocks of consecutive range epochs.
CALIBRATION_BLOCKS = 10


def calibration_rows(
    times: FloatArray, cap: int | None = CALIBRATION_EPOCHS, blocks: int = CALIBRATION_BLOCKS
) -> NDArray[np.intp] | None:
    """Row positions (ascending) of the ranges the calibration rounds fuse, or None for all.

    ``times``: each range's time. None when the session has ``cap`` distinct times or
    fewer (or ``cap`` is None). Otherwise the rows whose time is in one of ``blocks``
    blocks of ``cap // blocks`` consecutive distinct times, the blocks' starts spread
    evenly from the first distinct time to the last block that ends at the last one.
    Deterministic: it depends on the distinct times only (not on the row order).
    """
    if cap is None:
        return None
    if cap < 1 or blocks < 1:
        raise ValueError(f"calibration subset: cap {cap} and blocks {blocks} must be >= 1")
    unique, epoch = np.unique(np.asarray(times, dtype=np.float64), return_inverse=True)
    n = int(unique.shape[0])
    if n <= cap:
        return None
    blocks = min(blocks, cap)
    size = cap // blocks
    starts = np.round(np.linspace(0.0, float(n - size), blocks)).astype(np.int64)
    keep = np.zeros(n, dtype=bool)
    for start in starts:
        keep[start : start + size] = True
    return np.flatnonzero(keep[epoch.ravel()])
