"""Sets of time spans, (k, 2) start and end arrays: what is left of spans outside or inside
others. The figures' shaded gaps (:mod:`coopproc.report.gaps`) are made of them: a
no-reference span shows where it is not a UWB outage, an outage is a *navigation gap*
where an end's navigation is missing (run.json ``nav_gaps``).
"""

from __future__ import annotations

import numpy as np

from coopproc.model import FloatArray

__all__ = ["intersect", "merge", "subtract"]


def _spans(spans: FloatArray) -> FloatArray:
    return np.asarray(spans, dtype=np.float64).reshape(-1, 2)


def merge(spans: FloatArray) -> FloatArray:
    """``spans`` sorted by start with the overlapping or touching ones joined."""
    s = _spans(spans)
    if s.shape[0] < 2:
        return s.copy()
    s = s[np.argsort(s[:, 0], kind="stable")]
    ends = np.maximum.accumulate(s[:, 1])
    starts_new = np.concatenate([[True], s[1:, 0] > ends[:-1]])
    first = np.flatnonzero(starts_new)
    last = np.concatenate([first[1:] - 1, [s.shape[0] - 1]])
    return np.column_stack([s[first, 0], ends[last]])


def subtract(spans: FloatArray, cut: FloatArray, min_s: float) -> FloatArray:
    """The parts of ``spans`` outside every span of ``cut`` that are longer than ``min_s``.

    Only the cuts that overlap a span are applied to it (one that does not leaves it as
    it is): a platform of many pairs can have thousands of both, and trying every cut on
    every span cost seconds per figure at 20 platforms x 1 h."""
    out: list[tuple[float, float]] = []
    cut = _spans(cut)
    for start, end in _spans(spans):
        pieces = [(float(start), float(end))]
        overlap = (cut[:, 1] > start) & (cut[:, 0] < end)
        for lo, hi in cut[overlap]:
            pieces = [
                part
                for a, b in pieces
                for part in ((a, min(b, lo)), (max(a, hi), b))
                if part[1] > part[0]
            ]
        out.extend(p for p in pieces if p[1] - p[0] > min_s)
    return np.array(out, dtype=np.float64).reshape(-1, 2)


def intersect(spans: FloatArray, cut: FloatArray, min_s: float) -> FloatArray:
    """The parts of ``spans`` inside a span of ``cut`` that are longer than ``min_s``, in
    the order of ``spans``."""
    out: list[tuple[float, float]] = []
    cut = merge(cut)
    for start, end in _spans(spans):
        overlap = (cut[:, 1] > start) & (cut[:, 0] < end)
        for lo, hi in cut[overlap]:
            a, b = max(float(start), float(lo)), min(float(end), float(hi))
            if b - a > min_s:
                out.append((a, b))
    return np.array(out, dtype=np.float64).reshape(-1, 2)
