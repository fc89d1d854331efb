"""Axes-level plots of the evaluation: the horizontal-error CDF and the error-coloured track.

Like :mod:`coopproc.report.plots`: each function draws one panel (one platform's rows of
``positions.csv``) on the Axes it is given, with the styles of
:mod:`coopproc.report.style`, and returns what it drew; each line's ``gid`` is its series
key (the method name, ``reference``). The figures that stack these panels are
``error_cdf`` and ``error_track`` of :mod:`coopproc.report.figures`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PathCollection
from matplotlib.colors import Normalize

from coopproc.model import FloatArray
from coopproc.report.decimate import decimate, envelope_indices
from coopproc.report.gaps import break_gaps
from coopproc.report.methods import position_methods, primary_method
from coopproc.report.rundir import RunTables
from coopproc.report.style import method_style

__all__ = ["TRACK_CMAP", "error_norm", "plot_error_cdf", "plot_error_track", "track_method"]

#: Colour map of the error-coloured track (perceptually uniform, readable in grey).
TRACK_CMAP = "viridis"
#: The colour scale of the track ends at this percentile of the errors (outliers saturate).
_TOP_PERCENTILE = 95.0


def _values(frame: pd.DataFrame, column: str) -> FloatArray:
    return frame[column].to_numpy(dtype=np.float64, na_value=np.nan)


def _by_method(frame: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """The rows per method in row order, grouped once."""
    return {str(k): g for k, g in frame.groupby("method", sort=False, observed=True)}


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
    ax: Axes, platform_positions: pd.DataFrame, *, methods: Sequence[str] | None = None
) -> Axes:
    """Empirical CDF of the horizontal error ``error_h`` per method, overlaid.

    The curve of n errors steps up by 1/n at each sorted error (y = k/n at the k-th
    smallest); dotted lines at 0.5 and 0.95 read off CEP50 and CEP95. ``methods``
    default: every method of the rows but ``reference``, in row order.
    """
    by_method = _by_method(platform_positions)
    if methods is None:
        methods = [m for m in by_method if m != "reference"]
    for method in methods:
        if method not in by_method:
            continue
        h = np.sort(_values(by_method[method], "error_h"))
        h = h[np.isfinite(h)]
        if not h.size:
            continue
        y = np.arange(1, h.size + 1, dtype=np.float64) / h.size
        x, y = decimate(np.concatenate([[0.0], h]), np.concatenate([[0.0], y]))
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


def error_norm(errors: FloatArray) -> Normalize:
    """Colour scale of the track: 0 to the 95th percentile of the finite ``errors``."""
    h = np.asarray(errors, dtype=np.float64)
    h = h[np.isfinite(h)]
    top = float(np.percentile(h, _TOP_PERCENTILE)) if h.size else 1.0
    return Normalize(0.0, top if top > 0 else 1.0)


def plot_error_track(
    ax: Axes,
    platform_positions: pd.DataFrame,
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
    by_method = _by_method(platform_positions)
    empty = platform_positions.iloc[:0]
    ref = by_method.get("reference", empty).sort_values("time", kind="stable")
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
    own = by_method.get(method, empty).sort_values("time", kind="stable")
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
