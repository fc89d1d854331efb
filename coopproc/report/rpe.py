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
from coopproc.report.evaluation import aligned_tracks, evaluation_frame, evaluation_row
from coopproc.report.evaluation_extra import coverage_map
from coopproc.report.track_kernels import path_length, segment_ends, segment_errors

IntArray = NDArray[np.int64]

__all__ = [
    "DEFAULT_SEGMENTS_M",
    "RPE_COLUMNS",
    "check_segments",
    "evaluation_and_rpe",
    "rpe",
    "rpe_errors",
    "segments",
]

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
    q = np.ascontiguousarray(ref, dtype=np.float64).reshape(-1, 3)
    j = _ends(path_length(q), length_m)
    return np.arange(j.size, dtype=np.int64), j


def _ends(s: FloatArray, length_m: float) -> IntArray:
    if s.size < 2:
        return np.empty(0, dtype=np.int64)
    return np.asarray(segment_ends(s, float(length_m)), dtype=np.int64)


def rpe_errors(est: FloatArray, ref: FloatArray, length_m: float) -> FloatArray:
    """Translation error (m) of every segment of ``length_m`` (module doc), in start order."""
    p = np.ascontiguousarray(est, dtype=np.float64).reshape(-1, 3)
    q = np.ascontiguousarray(ref, dtype=np.float64).reshape(-1, 3)
    return segment_errors(p, q, segments(q, length_m)[1])


class _Segments:
    """The segment ends of the last reference track, per length: the methods of a
    platform share their reference (often the same array), so they are cut once."""

    def __init__(self) -> None:
        self._ref: FloatArray | None = None
        self._ends: dict[float, IntArray] = {}
        self._s: FloatArray = np.empty(0)

    def ends(self, ref: FloatArray, length_m: float) -> IntArray:
        last = self._ref
        same = last is not None and (
            ref is last or (ref.shape == last.shape and bool(np.array_equal(ref, last)))
        )
        if not same:
            self._ref, self._ends, self._s = ref, {}, path_length(ref)
        if length_m not in self._ends:
            self._ends[length_m] = _ends(self._s, length_m)
        return self._ends[length_m]


def _stats(err: FloatArray, length_m: float) -> dict[str, float]:
    finite = np.isfinite(err)
    if not bool(np.all(finite)):
        err = err[finite]
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


def _rpe_rows(
    item: tuple[str, str, str, FloatArray, FloatArray],
    lengths: Sequence[float],
    cache: _Segments,
) -> list[dict[str, object]]:
    platform, method, kind, moved, ref = item
    rows: list[dict[str, object]] = []
    for length in lengths:
        err = segment_errors(moved, ref, cache.ends(ref, length))
        row: dict[str, object] = {
            "platform": platform,
            "method": method,
            "alignment": kind,
            "segment_m": length,
            "segments": int(np.count_nonzero(np.isfinite(err))),
        }
        row.update(_stats(err, length))
        rows.append(row)
    return rows


def _rpe_frame(rows: list[dict[str, object]]) -> pd.DataFrame:
    out = pd.DataFrame(rows, columns=list(RPE_COLUMNS))
    out["segments"] = out["segments"].astype(np.int64)
    return out


def rpe(
    positions: pd.DataFrame,
    lengths_m: Sequence[float] = DEFAULT_SEGMENTS_M,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """``rpe.csv``: one row per platform, alignment, method and segment length (module doc)."""
    lengths = check_segments(lengths_m)
    cache = _Segments()
    rows: list[dict[str, object]] = []
    for platform, method, kind, _t, moved, ref, _transform in aligned_tracks(
        positions, align, methods
    ):
        rows += _rpe_rows((platform, method, kind, moved, ref), lengths, cache)
    return _rpe_frame(rows)


def evaluation_and_rpe(
    positions: pd.DataFrame,
    lengths_m: Sequence[float] = DEFAULT_SEGMENTS_M,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``evaluation.csv`` and ``rpe.csv`` (:func:`coopproc.report.evaluation.evaluation`,
    :func:`rpe`) from one pass over the aligned tracks: what a run writes, in a few seconds
    for a day of positions."""
    lengths = check_segments(lengths_m)
    cache = _Segments()
    ev_rows: list[dict[str, object]] = []
    rpe_rows: list[dict[str, object]] = []
    coverage = coverage_map(positions)
    for platform, method, kind, t, moved, ref, transform in aligned_tracks(
        positions, align, methods
    ):
        covered = coverage.get((platform, method), float("nan"))
        ev_rows.append(evaluation_row(platform, method, kind, moved, ref, transform, t, covered))
        rpe_rows += _rpe_rows((platform, method, kind, moved, ref), lengths, cache)
    return evaluation_frame(ev_rows), _rpe_frame(rpe_rows)
