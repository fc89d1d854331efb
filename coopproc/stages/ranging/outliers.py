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

The test (a Hampel identifier), on two series that must both call the epoch an outlier:
the ranges themselves, whose median over a short window follows a linear range change
exactly, and ``z_k = L_k - sum_{j<=k} I_j`` with I the pair's dead-reckoning DI, which
removes the platforms' motion (z is the range error plus the slowly accumulated DI error).
A gross error stands out in both; a jittering dead reckoning makes spikes in z alone (on
the real `tuc` session, two line-of-sight ranges of 4 and 12 cm error were called outliers
by z alone), a sharp turn near a pair's closest approach bends the ranges alone. Without a
DI (a tag's pairs) the ranges alone decide. Where the ranges alone cannot tell (a pair
moving metres between its epochs: real MiLUV's quadrotor at 0.8 Hz per anchor, 1.3 m), a
second witness of the motion can: ``z'_k = L_k - sum_{j<=k} I'_j`` with I' the DI of the
cooperative solution fused without the pair's own ranges (leave_out.py), whose errors are
the other pairs' and the fusion's, not this dead reckoning's jitter; an epoch far in both
z and z' is an outlier too. Measured through ``coopproc run`` (2026-12-07, each new one
against the reference): real MiLUV 6 (it had none), ranges 0.67-1.40 m long; real TIERS
1 more (1.16 m); none on `tuc`, `plaza2`, `sample_logs` and the 11 simulated comparison
sessions, whose outputs are byte-identical. On MiLUV's twins (benchmarks/twins.py, seeds
1-9) DI-fused / observed-fused went from 0.95-1.27 to 0.94-1.23 (docs/methods-ranging.md
#gross-outliers-outlierspy-rangingoutliers). Where the cooperative solution is the
navigation itself (no fusion, the tests' shortcut) I' is I and only the first rule
applies. On a series an epoch is far when

    |z_k - med_k| > max(k_sigma * s_k, min_m)

with med_k the median of z over ``half_window`` epochs either side and s_k the local
scale: 1.4826 x the median of |z - med| over ``scale_half_window`` epochs either side (so a
noisier stretch of the recording gets a wider gate, a clean one a narrower, and nothing
depends on the rest of the recording), and the gate at least :data:`MOTION_STEPS` times
the series' change next to the epoch (a fast-moving pair bends its median). Only runs of
at most ``max_run`` consecutive epochs beyond the first gate are outliers: a longer
excursion is NLOS (or a dead-reckoning fault) and goes to the distance filter, whose
detection handles it.

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

from coopproc.estimation.robust import MAD_SCALE
from coopproc.model import FloatArray
from coopproc.stages.ranging.calibration import accumulated

__all__ = ["MOTION_STEPS", "OutlierParams", "gross_outliers"]

#: The gate is at least this many of the series' changes next to the epoch (into its
#: neighbour before, out of its neighbour after): on the real `plaza2` session (ranges
#: changing by up to 9 m from one epoch to the next) departures of 1-2 m from the median
#: of 11 were the peaks of the range's own motion, not errors (the neighbours'
#: interpolation was worse than the range there). A single gross range is still caught;
#: two in a row shield each other.
MOTION_STEPS = 3.0


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


def _far(z: FloatArray, params: OutlierParams) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Epochs whose value departs from the local median by more than the local gate, and
    by more than the motion next to them too."""
    dev = np.abs(z - _centred_median(z, params.half_window))
    scale = MAD_SCALE * _centred_median(dev, params.scale_half_window)
    # a fast-changing series (a pair at its closest approach: the median of a V bends
    # away from it) moves this much per epoch next to k (the steps into k-1 and out of
    # k+1, not k's own): departures of a few such steps are motion
    n = z.shape[0]
    step = np.full(n + 1, np.nan)
    step[1:n] = np.abs(np.diff(z))  # step[j]: from j-1 to j
    before = np.full(n, np.nan)
    after = np.full(n, np.nan)
    before[2:] = step[1 : n - 1]  # z[k-1] - z[k-2]
    after[: n - 2] = step[2:n]  # z[k+2] - z[k+1]
    moving = MOTION_STEPS * np.nan_to_num(np.fmax(before, after))
    far = dev > np.fmax(params.k_sigma * scale, params.min_m)
    return np.asarray(far), np.asarray(far & (dev > moving))


def gross_outliers(
    range_m: FloatArray,
    di_m: FloatArray | None,
    params: OutlierParams,
    cp_di_m: FloatArray | None = None,
) -> NDArray[np.bool_]:
    """True at the range epochs that are gross outliers (see the module docstring).

    ``di_m``: the pair's dead-reckoning DI at each epoch (NaN where none; row 0 unused), or
    None. ``cp_di_m``: its DI from the cooperative solution fused without the pair's own
    ranges, or None (or the same as ``di_m``: no second witness). Non-finite ranges are
    never outliers (the readers refuse them).
    """
    n = range_m.shape[0]
    out = np.zeros(n, dtype=bool)
    if not params.enabled or n < 2 * params.half_window + 1:
        return out
    rng = np.asarray(range_m, dtype=np.float64)
    far, beyond_motion = _far(rng, params)
    if di_m is not None:
        far_z, beyond_z = _far(rng - accumulated(di_m), params)
        far &= far_z
        beyond_motion &= beyond_z
        if cp_di_m is not None and not np.allclose(di_m, cp_di_m, atol=1e-9, equal_nan=True):
            # the two motion-compensated series, each motion removed by a witness the
            # pair's own ranges did not make, agree on the epoch (module doc)
            far_c, beyond_c = _far(rng - accumulated(cp_di_m), params)
            far |= far_z & far_c
            beyond_motion |= beyond_z & beyond_c & far_z & far_c
    if not far.any():
        return out
    # runs of consecutive far epochs: only the short ones are outliers
    edges = np.diff(np.concatenate(([0], far.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    for lo, hi in zip(starts, ends, strict=True):
        if hi - lo <= params.max_run and beyond_motion[lo:hi].all():
            out[lo:hi] = True
    return out
