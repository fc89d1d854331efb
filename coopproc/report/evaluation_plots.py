"""Axes-level plots of the evaluation: the horizontal-error CDF and the error-coloured track.

Like :mod:`coopproc.report.plots`: each function draws one panel (one platform's rows of
``positions.csv``) on the Axes it is given, with the styles of
:mod:`coopproc.report.style`, and returns what it drew; each line's ``gid`` is its series
key (the method name, ``reference``). The figures that stack these panels are
``error_cdf`` and ``error_track`` of :mod:`coopproc.report.figures`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PathCollection
from matplotlib.colors import Normalize

from coopproc.model import FloatArray
from coopproc.report.decimate import decimate, envelope_indices
from coopproc.report.gaps import break_gaps
from coopproc.report.methods import position_methods, primary_method
from coopproc.report.panels import by_method as rows_by_method
from coopproc.report.panels import time_sorted
from coopproc.report.run_tables import RunTables
from coopproc.report.style import MAX_LINE_POINTS, method_style

__all__ = ["TRACK_CMAP", "error_norm", "plot_error_cdf", "plot_error_track", "track_method"]

#: Colour map of the error-coloured track (perceptually uniform, readable in grey).
TRACK_CMAP = "viridis"
#: The columns of an empty track (a method without rows).
_TRACK_COLUMNS = ("time", "east", "north", "error_h")
#: The colour scale of the track ends at this percentile of the errors (outliers saturate).
_TOP_PERCENTILE = 95.0


def _values(frame: pd.DataFrame, column: str) -> FloatArray:
    return frame[column].to_numpy(dtype=np.float64, na_value=np.nan)


def track_method(run: RunTables) -> str | None:
    """The method drawn in the error-coloured track: the primary method
    (:func:`~coopproc.report.methods.primary_method`, ``di`` by default) when it is a
    position method of the run, else the run's last position method; None without one."""
    methods = position_methods(run)
    primary = primary_method(run)
    if primary is not None and primary in methods:
        return primary
    return methods[-1] if methods else None


def plot_error_cdf(
    ax: Axes,
    platform_positions: pd.DataFrame | Mapping[str, pd.DataFrame],
    *,
    methods: Sequence[str] | None = None,
) -> Axes:
    """Empirical CDF of the horizontal error ``error_h`` per method, overlaid.

    The curve of n errors steps up by 1/n at each sorted error (y = k/n at the k-th
    smallest); dotted lines at 0.5 and 0.95 read off CEP50 and CEP95. Of a long series,
    the sorted errors drawn are those that begin and end each of
    :data:`~coopproc.report.style.MAX_LINE_POINTS` / 2 equal runs of ranks: the exact
    curve at a resolution finer than the panel's pixels. ``platform_positions``: the
    platform's rows, or its rows per method; ``methods`` default: every method of the
    rows but ``reference``, in row order.
    """
    by_method = rows_by_method(platform_positions)
    if methods is None:
        methods = [m for m in by_method if m != "reference"]
    for method in methods:
        if method not in by_method:
            continue
        h = np.sort(_values(by_method[method], "error_h"))
        h = h[np.isfinite(h)]
        if not h.size:
            continue
        x, y = _cdf_points(h)
        ax.plot(
            x,
            y,
            drawstyle="steps-post",
            gid=method,
            **method_style(method).kwargs(),
        )
    for level in (0.5, 0.95):
        ax.axhline(level, color="#999999", linestyle=":", linewidth=0.5)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlim(left=0.0)
    ax.set_xlabel("Horizontal error (m)")
    ax.set_ylabel("Fraction of epochs")
    return ax


def _cdf_points(sorted_h: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The points of the CDF of the sorted finite ``sorted_h`` drawn: (0, 0), then the
    k-th smallest error at y = k/n for the first and last rank of each of
    ``MAX_LINE_POINTS // 2`` equal runs of the n + 1 points (every rank when they are
    fewer): the min/max envelope of a rising curve (:func:`~coopproc.report.decimate.
    envelope_indices` of y), taken directly."""
    n = sorted_h.size
    x = np.concatenate([[0.0], sorted_h])
    if n + 1 <= MAX_LINE_POINTS:
        at = np.arange(n + 1)
    else:
        bucket = np.arange(n + 1, dtype=np.int64) * (MAX_LINE_POINTS // 2) // (n + 1)
        edge = np.flatnonzero(np.diff(bucket))
        at = np.unique(np.concatenate([[0, n], edge, edge + 1]))
    return x[at], at.astype(np.float64) / n


def error_norm(errors: FloatArray) -> Normalize:
    """Colour scale of the track: 0 to the 95th percentile of the finite ``errors``."""
    h = np.asarray(errors, dtype=np.float64)
    h = h[np.isfinite(h)]
    top = float(np.percentile(h, _TOP_PERCENTILE)) if h.size else 1.0
    return Normalize(0.0, top if top > 0 else 1.0)


def plot_error_track(
    ax: Axes,
    platform_positions: pd.DataFrame | Mapping[str, pd.DataFrame],
    method: str,
    *,
    norm: Normalize | None = None,
) -> PathCollection | None:
    """The track of ``method`` in the east-north plane, each epoch a dot coloured by its
    horizontal error, over the reference as a thin black line (equal axes) that breaks at
    the reference's gaps (:func:`~coopproc.report.gaps.break_gaps`).

    ``norm``: the colour scale (default :func:`error_norm` of these errors); returns the
    dots (for a colour bar), None when the method has no epoch with an error.
    """
    by_method = rows_by_method(platform_positions)
    empty = pd.DataFrame({c: pd.Series(dtype=np.float64) for c in _TRACK_COLUMNS})
    ref = time_sorted(by_method.get("reference", empty))
    if len(ref):
        style = method_style("reference")
        # no chord across a gap of the reference (float epochs, outages): NaN breaks
        _, ref_east, ref_north = decimate(
            *break_gaps(_values(ref, "time"), _values(ref, "east"), _values(ref, "north"))
        )
        ax.plot(
            ref_east,
            ref_north,
            gid="reference",
            label=style.label,
            color=style.color,
            linewidth=0.5,
        )
    own = time_sorted(by_method.get(method, empty))
    h = _values(own, "error_h")
    keep = np.isfinite(h)
    if not keep.any():
        return None
    # drawn: the largest and smallest errors of each stretch (the colour scale is all of them)
    at = np.flatnonzero(keep)[envelope_indices(h[keep])]
    dots = ax.scatter(
        _values(own, "east")[at],
        _values(own, "north")[at],
        c=h[at],
        s=2.0,
        cmap=TRACK_CMAP,
        norm=norm if norm is not None else error_norm(h),
        linewidths=0,
        gid=method,
        label=method_style(method).label,
        zorder=3,
    )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("East (m)")
    ax.set_ylabel("North (m)")
    return dots
