"""Relative position error per travelled distance (KITTI-style RPE): ``rpe.csv``.

Drift shows here, not in the absolute error: over every stretch of L metres travelled,
how far does the estimated displacement miss the reference displacement? Definitions
(restated in docs/report.md, "Relative error"):

- **Epochs**: those of the evaluation (:func:`coopproc.report.evaluation.matched_tracks`),
  after the alignment of the row (:mod:`coopproc.report.alignment`); ``none`` by default.
- **Travelled distance** ``s_k``: the 3-D path length of the *reference* up to epoch k
  (straight between consecutive epochs), as KITTI's devkit measures it on the ground truth.
- **Segments** of length L: from *every* epoch i (KITTI steps 10 frames; every epoch keeps
  this independent of the rate) to the first epoch j with ``s_j - s_i >= L``; a start with
  no such j (the last L metres) gives no segment.
- **Error** of a segment: ``|(p_j - p_i) - (q_j - q_i)|`` in metres (p estimate, q
  reference, 3-D); in % of the segment: ``100 * error / L`` (KITTI divides by the nominal
  length). ``positions.csv`` has no attitude, so the relative pose is a translation only:
  this is evo's RPE ``translation_part`` with identity orientations.

Per platform, alignment, method and L: ``segments``, and ``rmse_m``, ``mean_m``,
``median_m``, ``std_m`` (population), ``min_m``, ``max_m`` of the segment errors, and
``mean_pct``, ``max_pct``. No segment: every statistic empty, ``segments`` 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray
from coopproc.report.evaluation import aligned_tracks

IntArray = NDArray[np.int64]

__all__ = ["DEFAULT_SEGMENTS_M", "RPE_COLUMNS", "check_segments", "rpe", "rpe_errors", "segments"]

#: Segment lengths of ``rpe.csv`` written by ``coopproc run``, m.
DEFAULT_SEGMENTS_M: tuple[float, ...] = (10.0, 50.0, 100.0)
_STATS = ("rmse_m", "mean_m", "median_m", "std_m", "min_m", "max_m", "mean_pct", "max_pct")
#: Columns of ``rpe.csv``, in order.
RPE_COLUMNS: tuple[str, ...] = ("platform", "method", "alignment", "segment_m", "segments", *_STATS)


def check_segments(lengths: Sequence[float]) -> tuple[float, ...]:
    """Segment lengths as floats (each once, in order); ValueError for one not > 0."""
    out = []
    for value in lengths:
        length = float(value)
        if not (np.isfinite(length) and length > 0):
            raise ValueError(f"segment length {value!r}: expected a positive number of metres")
        out.append(length)
    return tuple(dict.fromkeys(out))


def segments(ref: FloatArray, length_m: float) -> tuple[IntArray, IntArray]:
    """Start and end epochs ``(i, j)`` of every segment of ``length_m`` along the (n, 3)
    reference (module doc): j the first epoch with ``s_j - s_i >= length_m``."""
    q = np.asarray(ref, dtype=np.float64).reshape(-1, 3)
    if q.shape[0] < 2:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    j = np.searchsorted(s, s + length_m, side="left")
    i = np.arange(s.size)
    keep = j < s.size
    return i[keep].astype(np.int64), j[keep].astype(np.int64)


def rpe_errors(est: FloatArray, ref: FloatArray, length_m: float) -> FloatArray:
    """Translation error (m) of every segment of ``length_m`` (module doc), in start order."""
    p = np.asarray(est, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(ref, dtype=np.float64).reshape(-1, 3)
    i, j = segments(q, length_m)
    miss = (p[j] - p[i]) - (q[j] - q[i])
    return np.sqrt(np.sum(miss * miss, axis=1))


def _stats(err: FloatArray, length_m: float) -> dict[str, float]:
    err = err[np.isfinite(err)]
    if not err.size:
        return dict.fromkeys(_STATS, float("nan"))
    return {
        "rmse_m": float(np.sqrt(np.mean(err * err))),
        "mean_m": float(np.mean(err)),
        "median_m": float(np.median(err)),
        "std_m": float(np.std(err)),
        "min_m": float(np.min(err)),
        "max_m": float(np.max(err)),
        "mean_pct": float(100.0 * np.mean(err) / length_m),
        "max_pct": float(100.0 * np.max(err) / length_m),
    }


def rpe(
    positions: pd.DataFrame,
    lengths_m: Sequence[float] = DEFAULT_SEGMENTS_M,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """``rpe.csv``: one row per platform, alignment, method and segment length (module doc)."""
    lengths = check_segments(lengths_m)
    rows: list[dict[str, object]] = []
    for platform, method, kind, _t, moved, ref, _transform in aligned_tracks(
        positions, align, methods
    ):
        for length in lengths:
            err = rpe_errors(moved, ref, length)
            row: dict[str, object] = {
                "platform": platform,
                "method": method,
                "alignment": kind,
                "segment_m": length,
                "segments": int(np.count_nonzero(np.isfinite(err))),
            }
            row.update(_stats(err, length))
            rows.append(row)
    out = pd.DataFrame(rows, columns=list(RPE_COLUMNS))
    out["segments"] = out["segments"].astype(np.int64)
    return out
