"""Fewer points for drawing long series, never for statistics.

A line of 300,000 samples in a panel 1,000 pixels wide draws every sample on top of its
neighbours: slow, and no more readable than a few thousand well-chosen points. The
*min/max envelope* keeps, in each of about ``max_points / 2`` buckets of consecutive
samples, the sample with the smallest and the one with the largest value of every
series, in their original order, so that a spike (an NLOS jump, an outlier) drawn from
one sample still shows at its full height. Buckets never span a gap: NaN samples (the
line breaks inserted by :func:`coopproc.report.gaps.break_gaps`) are all kept, and so
are the first and last sample of every run between them, so a line still stops and
starts where the data do. A series of at most ``max_points`` samples is returned as is.

How many points a panel can show is :func:`panel_points`: two (the bucket's minimum
and maximum) per pixel column of the Axes at :data:`~coopproc.report.style.DRAWN_DPI`,
at most :data:`~coopproc.report.style.MAX_LINE_POINTS`, so a line of a day costs what
one of an hour does.

Only the figures use this; every table and statistic is computed from the full data.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes

from coopproc.model import FloatArray
from coopproc.report.style import DRAWN_DPI, MAX_LINE_POINTS

__all__ = ["decimate", "envelope_indices", "panel_points"]


def panel_points(ax: Axes) -> int:
    """Most points worth drawing along the width of ``ax``: two per pixel column at
    :data:`~coopproc.report.style.DRAWN_DPI` (its width as laid out when drawn on),
    at most :data:`~coopproc.report.style.MAX_LINE_POINTS`."""
    fig = ax.get_figure(root=True)
    if fig is None:
        return MAX_LINE_POINTS
    width_in = ax.get_position().width * fig.get_figwidth()
    return max(2, min(MAX_LINE_POINTS, 2 * math.ceil(width_in * DRAWN_DPI)))


def envelope_indices(
    *series: FloatArray, max_points: int = MAX_LINE_POINTS
) -> np.ndarray[tuple[int], np.dtype[np.intp]]:
    """Sorted indices of the samples to draw (see the module docstring).

    ``series``: equal-length arrays; a sample is a gap when any series is NaN there.
    Keeps every NaN sample, the first and last finite sample of each run between gaps,
    and the minimum and maximum of every series in each bucket.
    """
    if not series:
        raise ValueError("envelope_indices needs at least one series")
    values = [np.asarray(s, dtype=np.float64) for s in series]
    n = values[0].shape[0]
    if any(v.shape != (n,) for v in values):
        raise ValueError("series must be one-dimensional and of equal length")
    if n <= max_points:
        return np.arange(n, dtype=np.intp)
    gap = np.zeros(n, dtype=bool)
    for v in values:
        gap |= ~np.isfinite(v)
    buckets = max(1, max_points // 2)
    bucket = np.arange(n, dtype=np.int64) * buckets // n
    run = np.cumsum(gap)  # a new run (and so a new bucket) after every gap sample
    finite = np.flatnonzero(~gap)
    if not finite.size:
        return np.flatnonzero(gap).astype(np.intp)
    # groups: consecutive finite samples of one bucket and one run
    key_change = np.ones(finite.size, dtype=bool)
    key_change[1:] = (np.diff(bucket[finite]) != 0) | (np.diff(run[finite]) != 0)
    starts = np.flatnonzero(key_change)
    group = np.cumsum(key_change) - 1
    # every gap sample, and the first and last finite sample of every run between gaps
    run_edge = np.flatnonzero(np.diff(run[finite]) != 0)
    keep = [np.flatnonzero(gap), finite[[0, -1]], finite[run_edge], finite[run_edge + 1]]
    for v in values:
        y = v[finite]
        for reduce in (np.minimum, np.maximum):
            extreme = reduce.reduceat(y, starts)
            hit = np.flatnonzero(y == extreme[group])
            first_hit = hit[np.unique(group[hit], return_index=True)[1]]
            keep.append(finite[first_hit])
    return np.unique(np.concatenate(keep)).astype(np.intp)


def decimate(
    x: FloatArray, *ys: FloatArray, max_points: int = MAX_LINE_POINTS
) -> tuple[FloatArray, ...]:
    """``x`` and ``ys`` at :func:`envelope_indices` of ``ys`` (all of them when short).

    ``x`` (time, east...) is taken along; the envelope is that of ``ys``.
    """
    at = envelope_indices(*ys, max_points=max_points)
    if at.size == np.asarray(x).shape[0]:
        return (np.asarray(x), *(np.asarray(y) for y in ys))
    return (np.asarray(x)[at], *(np.asarray(y)[at] for y in ys))
