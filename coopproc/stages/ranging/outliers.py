"""Gross range outliers: found on the range series itself, before either filter direction.

A gross range (a spike of metres, a 1999 m reading, a range to the wrong tag) is not NLOS:
NLOS lengthens the ranges for as long as the obstruction lasts, a gross error hits one or
two epochs. Taken by the distance filter it is an NLOS onset that the estimation window
(paper 000 eq. (11)) averages into its estimate, and, run backward as well
(:mod:`coopproc.stages.ranging.twoway`), it pulls the distance for seconds on both sides
(measured on ``sample_logs`` with a +100 m spike on B-C: 17 DI epochs off by > 0.3 m). So
the stage rejects such ranges first: their epochs are predicted only (the DI still
propagates the distance), their rows get ``outlier = 1`` in ``ranges.csv``, and every
method's output there is its filter's distance, not the range.

The test (a Hampel identifier on the motion-free series). ``z_k = L_k - sum_{j<=k} I_j``
with I the pair's dead-reckoning DI removes the platforms' motion, so z is the range error
plus the slowly accumulated DI error; without a DI (a tag's pairs), z is the range itself,
whose median over a short window still follows a linear range change exactly. An epoch is
an outlier when

    |z_k - med_k| > max(k_sigma * s_k, min_m)

with med_k the median of z over ``half_window`` epochs either side and s_k the local
scale: 1.4826 x the median of |z - med| over ``scale_half_window`` epochs either side (so a
noisier stretch of the recording gets a wider gate, a clean one a narrower, and nothing
depends on the rest of the recording). Only runs of at most ``max_run`` consecutive such
epochs are outliers: a longer excursion is NLOS (or a dead-reckoning fault) and goes to
the distance filter, whose detection handles it.

Defaults and the data they were chosen on: ``half_window = 5`` epochs resists runs of up
to 5 (the median of 11); ``max_run = 2`` leaves every event of 3 epochs or more to the
NLOS detection (paper 000's events last 10-20 s; on TIERS, 7.4 Hz, the shortest sustained
span the NLOS scoring counts is 3 epochs); ``k_sigma = 6`` (a 6-sigma range occurs once in
5 x 10^8 Gaussian epochs, a year at 10 Hz); ``min_m = 0.5`` m keeps the gate above what a
short obstruction does (NLOS excess of the shared real sessions up to 1.2 m over seconds,
not single epochs) on series whose local noise is tiny (exact simulated ranges).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray
from coopproc.stages.filters import MAD_SCALE

__all__ = ["OutlierParams", "gross_outliers"]


@dataclass(frozen=True)
class OutlierParams:
    """Gross-outlier rejection, TOML table ``[ranging.outliers]``."""

    enabled: bool = field(
        default=True, metadata={"help": "reject gross single ranges before the filters"}
    )
    k_sigma: float = field(
        default=6.0, metadata={"help": "gate in local robust sigmas of the range series"}
    )
    min_m: float = field(default=0.5, metadata={"help": "smallest gate, m"})
    half_window: int = field(default=5, metadata={"help": "epochs either side of the local median"})
    scale_half_window: int = field(
        default=30, metadata={"help": "epochs either side of the local robust scale"}
    )
    max_run: int = field(
        default=2,
        metadata={"help": "longest run of consecutive outlying epochs that is an outlier"},
    )

    def __post_init__(self) -> None:
        if self.k_sigma <= 0 or self.min_m < 0:
            raise ValueError("k_sigma must be > 0 and min_m >= 0")
        if self.half_window < 1 or self.scale_half_window < 1 or self.max_run < 1:
            raise ValueError("half_window, scale_half_window and max_run must be >= 1")


def _centred_median(values: FloatArray, half: int) -> FloatArray:
    """Median over ``half`` values either side (fewer at the ends), NaN-aware."""
    series = pd.Series(values)
    return series.rolling(2 * half + 1, center=True, min_periods=1).median().to_numpy()


def gross_outliers(
    range_m: FloatArray, di_m: FloatArray | None, params: OutlierParams
) -> NDArray[np.bool_]:
    """True at the range epochs that are gross outliers (see the module docstring).

    ``di_m``: the pair's dead-reckoning DI at each epoch (NaN where none; row 0 unused), or
    None. Non-finite ranges are never outliers (the readers refuse them).
    """
    n = range_m.shape[0]
    out = np.zeros(n, dtype=bool)
    if not params.enabled or n < 2 * params.half_window + 1:
        return out
    z = np.asarray(range_m, dtype=np.float64).copy()
    if di_m is not None:
        inc = np.where(np.isfinite(di_m), di_m, 0.0)
        inc[0] = 0.0
        z -= np.cumsum(inc)
    med = _centred_median(z, params.half_window)
    dev = np.abs(z - med)
    scale = MAD_SCALE * _centred_median(dev, params.scale_half_window)
    gate = np.fmax(params.k_sigma * scale, params.min_m)
    far = dev > gate
    if not far.any():
        return out
    # runs of consecutive far epochs: only the short ones are outliers
    edges = np.diff(np.concatenate(([0], far.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    for lo, hi in zip(starts, ends, strict=True):
        if hi - lo <= params.max_run:
            out[lo:hi] = True
    return out
