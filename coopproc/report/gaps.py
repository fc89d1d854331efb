"""Where the figures' time series have no data: the gap rule, line breaks and shaded spans.

A line plot joins consecutive samples, so a hole in the data (a UWB outage, reference
epochs dropped as float) would be drawn as a straight line, as if there were data. The
figures therefore break every time-series line at its gaps and shade the spans where data
are missing:

- **Gap rule** (:func:`line_gap_limit_s`): a step between consecutive (distinct) sample
  times is a gap when it is longer than :data:`~coopproc.model.GAP_FACTOR` (2.5) times the
  series' *cycle*, the longer of two estimates of its normal step (:func:`typical_step_s`):

  - the :data:`STEP_PERCENTILE` (90th) percentile of its steps, counted per step: a step
    taken by at least one sample in ten is never a gap (one step per outage, however
    long, is rarer than that by nature). Not the median: a platform's epochs are the
    range epochs of all its pairs, which come in bursts (A-B at .013 s, A-C at .034 s,
    then nothing until the next second), so its median step is the short step inside a
    burst.
  - the *time-weighted* :data:`TIME_SHARE` (75th) percentile of its steps: the longest
    of the shortest steps that together last three quarters of the series' time, over the
    steps up to 2.5 times the *lenient step*, the longest step once the
    :data:`LENIENT_SHARE` (1 %) longest steps, and at least :data:`LENIENT_MIN` (3), are
    passed over. With many pairs the once-a-cycle step between two bursts is taken by
    fewer than one sample in ten (19 pairs a burst: one in 19), so the 90th percentile is
    the millisecond step inside a burst and would mark every pause between bursts as an
    outage; but those pauses last most of the time, so the time-weighted percentile is
    their length. Likewise when the pairs come in a few groups a cycle (the longest pause,
    one step in 19, lasting 0.4 s of the second, the 90th percentile 0.24 s), a missed
    range that joins two pauses is no gap. Passing over the longest steps keeps a few long
    outages (which may last most of the time of a pair mostly out of range, or of a short
    series) from passing for the cycle: a pause between bursts is one step in at most 100
    for bursts of up to 100 pairs, so it is never passed over.

  On a regular or staggered series both estimates are the step itself, so the limit is
  the one of the 90th percentile alone; it is only ever longer (never shorter) than that.
  A one-burst-a-second series has a limit of about 2.5 x its pause between bursts (a
  missed burst is no gap, a hole of 2.5 s or more is).
- **Breaks** (:func:`break_gaps`): a NaN inserted in every gap, so the line stops there;
  :mod:`coopproc.report.decimate` keeps every NaN, so no decimated line bridges a gap.
- **Spans** (:func:`series_gaps`): *UWB outages*, gaps of a pair's range epochs (or of a
  platform's epochs, which are its range epochs), and *no reference*, gaps of the epochs
  that have a reference (outside the outages), each from the last sample before to the
  first after. A stretch missing at the start or the end of the run (``bounds``) counts
  when longer than the limit. Where the navigation of the platform (or of an end of the
  pair) is missing (run.json ``nav_gaps``: the run left out the ranges it did not cover),
  an outage is a *navigation gap* instead: the UWB ranged, the positions could not be
  processed. :func:`shade_gaps` draws them under the data: outages light grey (``gid``
  ``uwb_outage``, legend "UWB outage"), navigation gaps light sand (``nav_gap``,
  "Navigation gap"), no reference grey-hatched (``no_reference``, "No reference").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.path import Path

from coopproc.model import GAP_FACTOR, FloatArray, pair_members
from coopproc.report.span_sets import intersect, subtract

__all__ = [
    "LENIENT_MIN",
    "LENIENT_SHARE",
    "NAV_GAP_SPAN",
    "NO_REFERENCE_SPAN",
    "OUTAGE_SPAN",
    "STEP_PERCENTILE",
    "TIME_SHARE",
    "GapSpans",
    "break_gaps",
    "gap_spans",
    "line_gap_limit_s",
    "method_gaps",
    "pair_gaps",
    "platform_gaps",
    "series_gaps",
    "shade_gaps",
    "shade_spans",
    "shaded_spans",
    "typical_step_s",
]

#: Percentile of a series' steps (counted per step) that is never a gap (module docstring).
STEP_PERCENTILE = 90.0
#: Share of a series' time that its steps up to its time-weighted typical step last.
TIME_SHARE = 0.75
#: Share of a series' steps, the longest, that may be outages however long (module docstring).
LENIENT_SHARE = 0.01
#: ... and their least number, so that a short series' few outages are passed over too.
LENIENT_MIN = 3
#: ``axvspan`` styles of the spans: light grey, and grey hatching, both under the data.
OUTAGE_SPAN: dict[str, Any] = {"facecolor": "0.88", "edgecolor": "none", "zorder": 0.4}
#: ... and of a navigation gap: light sand, as flat as an outage (it is missing data too).
NAV_GAP_SPAN: dict[str, Any] = {"facecolor": "#eadfc8", "edgecolor": "none", "zorder": 0.4}
NO_REFERENCE_SPAN: dict[str, Any] = {
    "facecolor": "none",
    "edgecolor": "0.72",
    "hatch": "////",
    "linewidth": 0.0,
    "zorder": 0.45,
}
_EMPTY = np.empty((0, 2), dtype=np.float64)


def _distinct(time_s: FloatArray) -> FloatArray:
    """The distinct finite times of ``time_s``, sorted (``np.unique`` without its sort
    when they are sorted already, as a table's times are)."""
    t = np.asarray(time_s, dtype=np.float64)
    if t.size > 1 and bool(np.all(t[1:] >= t[:-1])):  # sorted, no NaN
        t = t[np.concatenate([[True], t[1:] != t[:-1]])]
        return t if np.isfinite(t[0]) and np.isfinite(t[-1]) else t[np.isfinite(t)]
    t = np.unique(t)
    return t[np.isfinite(t)]


def typical_step_s(time_s: FloatArray) -> float:
    """The normal step between the distinct finite times of ``time_s`` (in any order), s:
    the longer of the :data:`STEP_PERCENTILE` percentile of the steps and their
    time-weighted :data:`TIME_SHARE` percentile over the steps up to ``GAP_FACTOR`` times the
    lenient step (the longest step but the :func:`_lenient_rank` longest; see the module
    docstring); NaN with fewer than two distinct times."""
    t = _distinct(time_s)
    if t.shape[0] < 2:
        return float("nan")
    steps = np.sort(np.diff(t))
    counted = float(np.percentile(steps, STEP_PERCENTILE))
    rank = steps.size - 1 - _lenient_rank(steps.size)
    lenient = steps[rank] if rank >= 0 else counted
    kept = steps[: int(np.searchsorted(steps, GAP_FACTOR * lenient, side="right"))]
    if not kept.size:
        return counted
    carried = np.cumsum(kept)
    timed = kept[min(int(np.searchsorted(carried, TIME_SHARE * carried[-1])), kept.size - 1)]
    return float(max(counted, timed))


def _lenient_rank(n_steps: int) -> int:
    """How many of the longest steps may be outages and are passed over for the lenient
    step: :data:`LENIENT_SHARE` of the steps, at least :data:`LENIENT_MIN`."""
    return max(LENIENT_MIN, int(np.ceil(LENIENT_SHARE * n_steps)))


def line_gap_limit_s(time_s: FloatArray) -> float:
    """The longest step between samples that is not a gap, s: ``GAP_FACTOR`` times the
    :func:`typical_step_s` of ``time_s`` (in any order); infinite with fewer than two
    distinct times."""
    step = typical_step_s(time_s)
    return float("inf") if np.isnan(step) else GAP_FACTOR * step


def break_gaps(
    time_s: FloatArray, *series: FloatArray, limit_s: float | None = None
) -> tuple[FloatArray, ...]:
    """``time_s`` (sorted) and ``series`` with a NaN inserted in every step longer than
    ``limit_s`` (default :func:`line_gap_limit_s` of ``time_s``)."""
    t = np.asarray(time_s, dtype=np.float64)
    values = tuple(np.asarray(s, dtype=np.float64) for s in series)
    limit = line_gap_limit_s(t) if limit_s is None else limit_s
    at = np.flatnonzero(np.diff(t) > limit) + 1
    if not at.size:
        return (t, *values)
    return tuple(np.insert(v, at, np.nan) for v in (t, *values))


def gap_spans(
    time_s: FloatArray,
    *,
    limit_s: float | None = None,
    bounds: tuple[float, float] | None = None,
) -> FloatArray:
    """(k, 2) start and end of every step of the distinct finite ``time_s`` longer than
    ``limit_s`` (default :func:`line_gap_limit_s`); with ``bounds`` (first, last time of
    the run) also the stretches before the first and after the last sample when longer.
    Without samples, the whole of ``bounds`` (nothing without bounds)."""
    t = _distinct(time_s)
    if not t.size:
        return _EMPTY.copy() if bounds is None else np.array([bounds], dtype=np.float64)
    limit = line_gap_limit_s(t) if limit_s is None else limit_s
    at = np.flatnonzero(np.diff(t) > limit)
    spans = [np.column_stack([t[at], t[at + 1]])]
    if bounds is not None:
        lo, hi = bounds
        if t[0] - lo > limit:
            spans.insert(0, np.array([[lo, t[0]]]))
        if hi - t[-1] > limit:
            spans.append(np.array([[t[-1], hi]]))
    return np.concatenate(spans).astype(np.float64)


@dataclass(frozen=True)
class GapSpans:
    """Spans without data of one pair or platform, (k, 2) start and end times, s."""

    #: No ranges (a pair's UWB outage; for a platform: none of its pairs ranged).
    outages: FloatArray
    #: Epochs present but without a reference (float or missing reference epochs).
    no_reference: FloatArray
    #: No data because an end's navigation is missing (run.json ``nav_gaps``): the parts
    #: of what would be outages that lie in a navigation gap, not among ``outages``.
    nav_gaps: FloatArray = field(default_factory=lambda: _EMPTY.copy())

    def shifted(self, origin_s: float) -> GapSpans:
        """The spans with ``origin_s`` subtracted (times as drawn)."""
        return GapSpans(
            self.outages - origin_s, self.no_reference - origin_s, self.nav_gaps - origin_s
        )


def series_gaps(
    time_s: FloatArray,
    has_reference: np.ndarray,
    *,
    bounds: tuple[float, float] | None = None,
    nav_gaps: FloatArray | None = None,
) -> GapSpans:
    """The outages and no-reference spans of a series of epochs ``time_s`` of which
    ``has_reference`` have a reference (see the module docstring). The no-reference spans
    use the limit of the epochs with a reference (the one that breaks their lines).
    ``nav_gaps``: where the navigation of the series' platform (or of an end of its pair)
    is missing; the parts of the outages inside them are navigation gaps instead, and
    what is left of an outage shows when it is itself a gap."""
    t = np.asarray(time_s, dtype=np.float64)
    ok = np.asarray(has_reference, dtype=bool) & np.isfinite(t)
    limit = line_gap_limit_s(t)
    missing_data = gap_spans(t, limit_s=limit, bounds=bounds)
    outages, nav = missing_data, _EMPTY
    if nav_gaps is not None and len(nav_gaps):
        nav = intersect(missing_data, nav_gaps, limit)
        outages = subtract(missing_data, nav_gaps, limit)
    ref_t = t[ok]
    if not ref_t.size:
        span = np.unique(t[np.isfinite(t)])
        missing = np.array([[span[0], span[-1]]]) if span.size > 1 else _EMPTY
        return GapSpans(outages, subtract(missing, missing_data, 0.0), nav)
    ref_limit = line_gap_limit_s(ref_t)
    within = (float(np.nanmin(t)), float(np.nanmax(t)))
    missing = gap_spans(ref_t, limit_s=ref_limit, bounds=within)
    # what an outage leaves of a no-reference gap shows when it is itself a gap
    return GapSpans(outages, subtract(missing, missing_data, ref_limit), nav)


def _bounds(frames: Mapping[Any, pd.DataFrame]) -> tuple[float, float] | None:
    times = [f["time"].to_numpy(dtype=np.float64) for f in frames.values() if len(f)]
    if not times:
        return None
    return min(float(np.nanmin(t)) for t in times), max(float(np.nanmax(t)) for t in times)


def _members_nav(name: str, nav_gaps: Mapping[str, FloatArray] | None) -> FloatArray | None:
    """The navigation gaps of a platform, or of both ends of a pair, together."""
    if not nav_gaps:
        return None
    try:
        members: tuple[str, ...] = pair_members(name)
    except ValueError:
        members = (name,)
    parts = [nav_gaps[m] for m in members if m in nav_gaps]
    return np.concatenate(parts) if parts else None


def pair_gaps(
    ranges_by_pair: Mapping[str, pd.DataFrame],
    nav_gaps: Mapping[str, FloatArray] | None = None,
) -> dict[str, GapSpans]:
    """The spans of each pair from its rows of ``ranges.csv`` (every range, with or without
    a reference; ``reference`` gives the no-reference spans); the run's bounds are those
    of all the pairs' ranges. ``nav_gaps`` (:func:`nav_gaps_of`): the outages where an end's
    navigation is missing are navigation gaps."""
    bounds = _bounds(ranges_by_pair)
    return {
        pair: series_gaps(
            rows["time"].to_numpy(dtype=np.float64),
            rows["reference"].notna().to_numpy(),
            bounds=bounds,
            nav_gaps=_members_nav(pair, nav_gaps),
        )
        for pair, rows in ranges_by_pair.items()
    }


def platform_gaps(
    positions_by_platform: Mapping[str, pd.DataFrame],
    nav_gaps: Mapping[str, FloatArray] | None = None,
) -> dict[str, GapSpans]:
    """The spans of each platform from its rows of ``positions.csv`` (those of the methods
    drawn; an epoch has a reference when one of them has an ``error_h``); the bounds are
    those of all the rows given; ``nav_gaps`` as for :func:`pair_gaps`."""
    bounds = _bounds(positions_by_platform)
    return {
        platform: series_gaps(
            rows["time"].to_numpy(dtype=np.float64),
            rows["error_h"].notna().to_numpy(),
            bounds=bounds,
            nav_gaps=_members_nav(platform, nav_gaps),
        )
        for platform, rows in positions_by_platform.items()
        if len(rows)
    }


def method_gaps(
    rows_by_platform: Mapping[str, Mapping[str, pd.DataFrame]],
    nav_gaps: Mapping[str, FloatArray] | None = None,
) -> dict[str, GapSpans]:
    """:func:`platform_gaps` of each platform's rows given per method (the rows of all its
    methods together), one platform's epochs at a time: at a day of 10 platforms all of
    them together were ~0.4 GB in each figure worker (issue 11). The same spans."""
    every = {(p, m): r for p, rows in rows_by_platform.items() for m, r in rows.items()}
    bounds = _bounds(every)
    out = {}
    for platform, rows in rows_by_platform.items():
        parts = [r for r in rows.values() if len(r)]
        if not parts:
            continue
        time_s = np.concatenate([r["time"].to_numpy(dtype=np.float64) for r in parts])
        has_reference = np.concatenate([r["error_h"].notna().to_numpy() for r in parts])
        own = _members_nav(platform, nav_gaps)
        out[platform] = series_gaps(time_s, has_reference, bounds=bounds, nav_gaps=own)
    return out


def _rectangles(spans: FloatArray) -> tuple[FloatArray, np.ndarray]:
    """Vertices and codes of one compound path of a closed rectangle per span, from the
    bottom (0) to the top (1) of the axes."""
    x = spans[:, [0, 0, 1, 1, 0]]
    y = np.broadcast_to([0.0, 1.0, 1.0, 0.0, 0.0], x.shape)
    codes = np.tile(
        np.array([Path.MOVETO, Path.LINETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY]),
        spans.shape[0],
    ).astype(Path.code_type)
    return np.column_stack([x.ravel(), y.ravel()]), codes


def shade_gaps(ax: Axes, gaps: GapSpans | None) -> None:
    """Shade ``gaps`` (times as drawn) on ``ax`` under the data, each kind labelled once.

    Each kind is one artist, one compound path of rectangles spanning the axes' height
    (what ``axvspan`` draws per span, with its ``gid``, label and style): a platform of
    many pairs can have thousands of spans, and one artist (or one hatched path) per span
    cost tens of seconds a day of data. The spans are neither joined (spans under a pixel
    apart would look like one span without data) nor left unsnapped: each is drawn on
    whole pixels, as one path per span is, so the pixels are those of drawing them one by
    one. The spans' times count in the x data limits, as ``axvspan``'s do."""
    if gaps is None:
        return
    kinds = (
        (gaps.outages, "uwb_outage", "UWB outage", OUTAGE_SPAN),
        (gaps.nav_gaps, "nav_gap", "Navigation gap", NAV_GAP_SPAN),
        (gaps.no_reference, "no_reference", "No reference", NO_REFERENCE_SPAN),
    )
    for spans, gid, label, style in kinds:
        shade_spans(ax, spans, gid, label, style)


def shade_spans(
    ax: Axes, spans: FloatArray, gid: str, label: str, style: Mapping[str, Any]
) -> None:
    """Shade ``spans`` (times as drawn) on ``ax`` as one artist with ``gid``, ``label``
    and ``style`` (``PolyCollection`` keywords), as :func:`shade_gaps` draws each kind."""
    spans = np.asarray(spans, dtype=np.float64).reshape(-1, 2)
    if not spans.shape[0]:
        return
    verts, codes = _rectangles(spans)
    shade = PolyCollection([], transform=ax.get_xaxis_transform(which="grid"), label=label, **style)
    shade.set_verts_and_codes([verts], [codes])  # type: ignore[list-item]
    shade.set_gid(gid)
    # every rectangle on whole pixels, as one path per span is (matplotlib snaps
    # paths of up to 1024 vertices only): sub-pixel spans look as they did one by one
    shade.set_snap(True)
    ax.add_collection(shade, autolim=False)
    ax.update_datalim(np.column_stack([spans.ravel(), np.zeros(spans.size)]), updatey=False)
    # a lazy x autoscale request as axvspan's, if on (an eager set_xlim here: 7 s)
    ax.autoscale(ax.get_autoscalex_on(), axis="x")


def shaded_spans(ax: Axes, gid: str) -> FloatArray:
    """(k, 2) start and end, as drawn, of the spans :func:`shade_gaps` shaded on ``ax``
    with ``gid`` (``uwb_outage``, ``nav_gap``, ``no_reference``), in drawing order."""
    polygons = [
        np.asarray(v, dtype=np.float64)[:, 0]
        for shade in ax.collections
        if shade.get_gid() == gid
        for path in shade.get_paths()
        for v in path.to_polygons(closed_only=False)
    ]
    out = [(float(x.min()), float(x.max())) for x in polygons]
    return np.array(out, dtype=np.float64).reshape(-1, 2)
