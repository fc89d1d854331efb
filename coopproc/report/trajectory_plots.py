"""Trajectory panels: one platform's tracks in the east-north plane, readable on paper.

A 150 m track whose methods differ by a few centimetres draws every method on top of
the others; :func:`plot_trajectory` therefore draws, on the Axes it is given:

- the reference (black), the platform's own navigation (grey, dotted) and each position
  method in its style (:mod:`coopproc.report.style`), each line's ``gid`` its method;
- the start (white circle, ``gid`` ``start``, legend "Start") and end (black square,
  ``end``, "End") of the track (the reference's, else the first method's);
- the anchors (fixed platforms, role ``anchor``; ``gid`` ``anchors``, legend "Anchor"),
  as triangles named by their ids;
- a zoomed inset (``gid`` ``zoom``) when the methods' errors are small against the size of
  the track (95th percentile below :data:`ZOOM_FRACTION` of it): a square window around
  the epoch where the methods' horizontal errors differ most, placed beside the track
  (never on it), its width in metres written in it.

No line is drawn across a gap: a track breaks where consecutive epochs are further
apart than :func:`~coopproc.report.gaps.line_gap_limit_s` (the rule of every time-series
figure: a platform's epochs come in bursts, so the median step would break every burst).
Long tracks are drawn from their min/max envelope (:mod:`coopproc.report.decimate`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

from coopproc.model import FloatArray
from coopproc.report.decimate import decimate
from coopproc.report.gaps import break_gaps, line_gap_limit_s
from coopproc.report.methods import position_methods_of
from coopproc.report.panels import by_method as rows_by_method
from coopproc.report.panels import time_sorted
from coopproc.report.run_tables import RunTables
from coopproc.report.style import method_style

__all__ = [
    "ANCHOR_MARKER",
    "END_MARKER",
    "START_MARKER",
    "ZOOM_FRACTION",
    "mark_anchors",
    "mark_start_end",
    "plot_trajectory",
    "run_anchors",
    "track_xy",
]

#: Marker styles (``Axes.plot`` keywords) of the start, the end and the anchors.
START_MARKER: dict[str, Any] = {
    "marker": "o",
    "markersize": 4.5,
    "markerfacecolor": "white",
    "markeredgecolor": "black",
    "markeredgewidth": 0.9,
    "linestyle": "none",
    "label": "Start",
    "zorder": 5,
}
END_MARKER: dict[str, Any] = {
    "marker": "s",
    "markersize": 4.0,
    "markerfacecolor": "black",
    "markeredgecolor": "black",
    "linestyle": "none",
    "label": "End",
    "zorder": 5,
}
ANCHOR_MARKER: dict[str, Any] = {
    "marker": "^",
    "markersize": 5.5,
    "markerfacecolor": "#8c564b",
    "markeredgecolor": "black",
    "markeredgewidth": 0.5,
    "linestyle": "none",
    "label": "Anchor",
    "zorder": 4,
}
#: A zoomed inset is drawn when the 95th percentile of the methods' horizontal errors is
#: below this fraction of the track's size (the lines would otherwise overlap).
ZOOM_FRACTION = 0.03
#: The inset is this fraction of the track's size, square.
_ZOOM_SIZE = 0.45


def _values(frame: pd.DataFrame, column: str) -> FloatArray:
    return frame[column].to_numpy(dtype=np.float64, na_value=np.nan)


def track_xy(
    time_s: FloatArray,
    east: FloatArray,
    north: FloatArray,
    *,
    reduce: bool = True,
    limit_s: float | None = None,
) -> tuple[FloatArray, FloatArray]:
    """East and north of a track (sorted by time, finite) with a NaN in every time gap
    (longer than ``limit_s``, default :func:`~coopproc.report.gaps.line_gap_limit_s`),
    so that a line plot draws no chord across it; decimated for drawing if ``reduce``."""
    if time_s.size > 1:
        time_s, east, north = break_gaps(time_s, east, north, limit_s=limit_s)
    if reduce:
        _, east, north = decimate(time_s, east, north)
    return east, north


def run_anchors(run: RunTables) -> dict[str, tuple[float, float]]:
    """The anchors' east and north by id, from run.json ``session.anchors`` (empty when
    the run has none or predates it)."""
    session = run.info.get("session")
    anchors = session.get("anchors") if isinstance(session, Mapping) else None
    if not isinstance(anchors, Mapping):
        return {}
    out = {}
    for name, position in anchors.items():
        if isinstance(position, Sequence) and len(position) >= 2:
            out[str(name)] = (float(position[0]), float(position[1]))
    return out


def mark_start_end(ax: Axes, east: FloatArray, north: FloatArray) -> None:
    """The start (circle) and end (square) of a track, labelled for the legend."""
    keep = np.flatnonzero(np.isfinite(east) & np.isfinite(north))
    if not keep.size:
        return
    first, last = keep[0], keep[-1]
    ax.plot(east[first : first + 1], north[first : first + 1], gid="start", **START_MARKER)
    ax.plot(east[last : last + 1], north[last : last + 1], gid="end", **END_MARKER)


def mark_anchors(ax: Axes, anchors: Mapping[str, tuple[float, float]]) -> None:
    """The anchors as triangles, each named by its id (small text beside it)."""
    if not anchors:
        return
    names = sorted(anchors)
    east = np.array([anchors[n][0] for n in names])
    north = np.array([anchors[n][1] for n in names])
    ax.plot(east, north, gid="anchors", **ANCHOR_MARKER)
    # room under each anchor for its name (the frame would cut it at the edge)
    box = ax.dataLim
    pad = 0.08 * max(box.width, box.height) if np.isfinite(box.width) else 0.0
    ax.update_datalim(np.column_stack([east, north - pad]))
    for name, e, n in zip(names, east, north, strict=True):
        ax.annotate(
            name,
            (e, n),
            xytext=(3, -3),
            textcoords="offset points",
            fontsize="x-small",
            color="#5a3a2e",
            va="top",
        )


def _zoom_window(
    tracks: Mapping[str, pd.DataFrame], methods: Sequence[str], size_m: float
) -> tuple[float, float, float] | None:
    """Centre (east, north) and half width of the zoom, None when no zoom is needed.

    The zoom shows the epoch, among those where the reference and every one of
    ``methods`` have a position, at which the methods' horizontal errors differ most
    (largest minus smallest), wide enough to hold every method's position there."""
    errors = [_values(tracks[m], "error_h") for m in methods]
    h = np.concatenate(errors) if errors else np.empty(0)
    h = h[np.isfinite(h)]
    if not h.size or not size_m > 0:
        return None
    if np.percentile(h, 95.0) >= ZOOM_FRACTION * size_m:
        return None  # the methods are apart at the panel's scale already
    keyed = [_first_per_time(tracks[m]) for m in ("reference", *methods)]
    common = keyed[0][0]
    for t, _, _ in keyed[1:]:
        common = common[_rows_at(t, common) >= 0]
    if not common.size:
        return None
    at_rows = [_rows_at(t, common) for t, _, _ in keyed]
    east = np.column_stack([e[i] for (_, e, _), i in zip(keyed, at_rows, strict=True)])
    north = np.column_stack([n[i] for (_, _, n), i in zip(keyed, at_rows, strict=True)])
    dist = np.hypot(east - east[:, :1], north - north[:, :1])[:, 1:]  # from the reference
    spread = np.nanmax(dist, axis=1) - np.nanmin(dist, axis=1)
    if not np.isfinite(spread).any():
        return None
    at = int(np.nanargmax(spread))
    ce, cn = float(np.mean(east[at])), float(np.mean(north[at]))
    reach = float(np.max(np.hypot(east[at] - ce, north[at] - cn)))
    return ce, cn, max(1.8 * reach, 0.002 * size_m, 0.01)


def _first_per_time(rows: pd.DataFrame) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Time (sorted), east and north of the first row at each time of ``rows`` (in time
    order)."""
    t, east, north = (_values(rows, c) for c in ("time", "east", "north"))
    first = np.concatenate([[True], t[1:] != t[:-1]]) if t.size else np.ones(0, dtype=bool)
    return t[first], east[first], north[first]


def _rows_at(sorted_t: FloatArray, times: FloatArray) -> np.ndarray:
    """Index in ``sorted_t`` (sorted, distinct) of each of ``times``; -1 where absent."""
    if sorted_t.size == times.size and np.array_equal(sorted_t, times):  # the same epochs
        return np.arange(times.size)
    at = np.searchsorted(sorted_t, times)
    at[at >= sorted_t.size] = 0
    found = sorted_t[at] == times if sorted_t.size else np.zeros(times.size, dtype=bool)
    return np.where(found, at, -1)


def _inset(
    ax: Axes,
    tracks: Mapping[str, pd.DataFrame],
    window: tuple[float, float, float],
    box: tuple[float, float, float, float],
    limits: Mapping[str, float],
) -> None:
    """The zoomed inset beside the track's bounding ``box`` (east0, north0, east1, north1);
    ``limits``: each track's gap limit (that of its whole track)."""
    e0, n0, e1, n1 = box
    width, height = e1 - e0, n1 - n0
    side = _ZOOM_SIZE * max(width, height)
    gap = 0.06 * max(width, height)
    if width >= height:  # below the track, at its right end
        bounds = (e1 - side, n0 - gap - side, side, side)
    else:  # right of the track, at its top
        bounds = (e1 + gap, n1 - side, side, side)
    ax.update_datalim([(bounds[0], bounds[1]), (bounds[0] + side, bounds[1] + side)])
    inset = ax.inset_axes(bounds, transform=ax.transData)
    inset.set_gid("zoom")
    ce, cn, half = window
    for method, rows in tracks.items():
        time_s, east, north = (_values(rows, c) for c in ("time", "east", "north"))
        near = (np.abs(east - ce) < 3 * half) & (np.abs(north - cn) < 3 * half)
        if not near.any():
            continue
        limit = limits[method]  # the whole track's epochs
        x, y = track_xy(time_s[near], east[near], north[near], reduce=False, limit_s=limit)
        style = method_style(method).kwargs()
        style["label"] = "_nolegend_"
        inset.plot(x, y, gid=method, marker=".", markersize=2.0, **style)
    inset.set_xlim(ce - half, ce + half)
    inset.set_ylim(cn - half, cn + half)
    inset.set_aspect("equal", adjustable="box")
    inset.set_xticks([])
    inset.set_yticks([])
    inset.grid(False)
    inset.text(
        0.04,
        0.96,
        f"{2 * half:.2g} m",
        transform=inset.transAxes,
        fontsize="x-small",
        va="top",
        bbox={"facecolor": "white", "alpha": 0.8, "linewidth": 0, "pad": 1.0},
        zorder=6,
    )
    ax.indicate_inset_zoom(inset, edgecolor="0.35", linewidth=0.6)


def plot_trajectory(
    ax: Axes,
    platform_positions: pd.DataFrame | Mapping[str, pd.DataFrame],
    *,
    methods: Sequence[str] | None = None,
    anchors: Mapping[str, tuple[float, float]] | None = None,
    zoom: bool = True,
) -> Axes:
    """The platform's track per method, start and end marked, ``anchors`` (east, north
    by id) drawn, and a zoomed inset where the methods overlap (see the module docstring).

    ``platform_positions``: the platform's rows, or its rows per method; ``methods``
    default: ``reference``, ``nav``, then the position methods of the rows.
    """
    by_method = rows_by_method(platform_positions)
    if methods is None:
        names = pd.DataFrame({"method": list(by_method)})
        methods = ("reference", "nav", *position_methods_of(names))
    tracks: dict[str, pd.DataFrame] = {}
    for method in methods:
        if method not in by_method:
            continue
        rows = time_sorted(by_method[method])
        keep = np.isfinite(_values(rows, "east")) & np.isfinite(_values(rows, "north"))
        if keep.all():
            tracks[method] = rows
        elif keep.any():
            tracks[method] = rows[keep]
    limits: dict[str, float] = {}
    for method, rows in tracks.items():
        style = method_style(method)
        time_s, east, north = (_values(rows, c) for c in ("time", "east", "north"))
        limits[method] = line_gap_limit_s(time_s)
        x, y = track_xy(time_s, east, north, limit_s=limits[method])
        ax.plot(x, y, gid=method, **style.kwargs(east.size))
    if tracks:
        first = tracks.get("reference", next(iter(tracks.values())))
        mark_start_end(ax, _values(first, "east"), _values(first, "north"))
    mark_anchors(ax, anchors or {})
    # the zoom window: judged on the methods (not the own navigation, which may drift away)
    fused = [m for m in tracks if m not in ("reference", "nav")]
    ref = tracks.get("reference")
    if zoom and fused and ref is not None:
        east, north = _values(ref, "east"), _values(ref, "north")
        box = (float(east.min()), float(north.min()), float(east.max()), float(north.max()))
        window = _zoom_window(tracks, fused, max(box[2] - box[0], box[3] - box[1]))
        if window is not None:
            _inset(ax, tracks, window, _data_box(tracks, anchors or {}), limits)
    ax.set_xlabel("East (m)")
    ax.set_ylabel("North (m)")
    ax.set_aspect("equal", adjustable="datalim")
    return ax


def _data_box(
    tracks: Mapping[str, pd.DataFrame], anchors: Mapping[str, tuple[float, float]]
) -> tuple[float, float, float, float]:
    """The bounding box of every track and anchor drawn."""
    east = [_values(r, "east") for r in tracks.values()]
    north = [_values(r, "north") for r in tracks.values()]
    east.append(np.array([a[0] for a in anchors.values()], dtype=np.float64))
    north.append(np.array([a[1] for a in anchors.values()], dtype=np.float64))
    e, n = np.concatenate(east), np.concatenate(north)
    return float(e.min()), float(n.min()), float(e.max()), float(n.max())
