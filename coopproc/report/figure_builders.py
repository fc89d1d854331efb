"""The figures' panel builders: for each figure of :mod:`coopproc.report.figures`, the
panels the run's data allow (one per pair, platform or NLOS event) and how each is drawn.

``BUILDERS`` maps a figure name to its builder; a builder returns ``None`` when the run
has no data for the figure. :class:`FigureGroups` groups the run's rows per pair and
platform once for all figures and computes the shaded gap spans when a page first needs
them (:mod:`coopproc.report.gaps`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.report.consistency_figure import consistency_panels
from coopproc.report.convergence import convergence_panels
from coopproc.report.dr_states_figure import dr_states_panels
from coopproc.report.evaluation_plots import (
    error_norm,
    plot_error_cdf,
    plot_error_track,
    track_method,
)
from coopproc.report.gaps import (
    GapSpans,
    line_gap_limit_s,
    method_gaps,
    pair_gaps,
)
from coopproc.report.methods import position_methods, primary_method, range_methods
from coopproc.report.outage_figure import outage_panels
from coopproc.report.pages import FigureOptions
from coopproc.report.panel_cap import event_score
from coopproc.report.panels import (
    Panels,
    colorbar_below,
    grid_layout,
    groups,
    legend,
    stack_layout,
    time_label,
)
from coopproc.report.plots import (
    plot_di_errors,
    plot_distance_errors,
    plot_nlos_convergence,
    plot_position_errors,
)
from coopproc.report.run_spans import nav_gaps_of, outage_windows_of, shade_windows
from coopproc.report.run_tables import RunTables
from coopproc.report.trajectory_plots import (
    mark_anchors,
    mark_start_end,
    plot_trajectory,
    run_anchors,
)

__all__ = ["BUILDERS", "FigureGroups"]


def _has(frame: pd.DataFrame, column: str) -> pd.Series:
    return frame[column].notna()


class FigureGroups:
    """The run's rows per pair / platform (and a platform's per method), grouped once and
    shared by the figures: slices of the tables, not copies (a day: 38 M position rows)."""

    def __init__(self, run: RunTables) -> None:
        self.run = run
        self._cache: dict[str, dict[str, pd.DataFrame]] = {}
        self._methods: dict[str, Mapping[str, pd.DataFrame]] = {}
        self._gaps: dict[str, dict[str, GapSpans]] = {}

    def positions(self) -> dict[str, pd.DataFrame]:
        if "positions" not in self._cache:
            self._cache["positions"] = groups(self.run.positions, "platform")
        return self._cache["positions"]

    def methods(self, platform: str) -> Mapping[str, pd.DataFrame]:
        """The platform's rows per method (:func:`~coopproc.report.panels.groups`)."""
        if platform not in self._methods:
            self._methods[platform] = groups(self.positions()[platform], "method")
        return self._methods[platform]

    def ranges(self) -> dict[str, pd.DataFrame]:
        if "ranges" not in self._cache:
            self._cache["ranges"] = groups(self.run.ranges, "pair")
        return self._cache["ranges"]

    def gaps(self, key: str, make: Callable[[], dict[str, GapSpans]]) -> dict[str, GapSpans]:
        """Shaded spans, made when a page first draws them (report.html's listing: none)."""
        return self._gaps[key] if key in self._gaps else self._gaps.setdefault(key, make())


def _time_finish(origin_s: float) -> Callable[[Figure, list[Axes], list[Any]], None]:
    def finish(fig: Figure, axes: list[Axes], drawn: list[Any]) -> None:
        time_label(axes, origin_s)
        legend(fig, axes)

    return finish


def _distance_errors(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """Paper 000 fig. 9/11: one panel per pair that has a reference distance."""
    by_pair = {
        p: rows[_has(rows, "reference")] for p, rows in g.ranges().items() if opts.keep_pair(p)
    }
    pairs = sorted(p for p, rows in by_pair.items() if len(rows))
    if not pairs:
        return None
    t0 = run.time_origin_s
    methods = range_methods(run)
    events = run.nlos_events
    primary = primary_method(run)
    if primary is not None and primary in set(events["method"]):
        events = events[events["method"] == primary]
    events_by_pair = groups(events, "pair")
    no_events = events.iloc[:0]
    windows = outage_windows_of(run.info)

    def draw(ax: Axes, i: int) -> None:
        pair = pairs[i]
        rows, shaded = by_pair[pair], events_by_pair.get(pair, no_events)
        gaps = g.gaps("pairs", lambda: pair_gaps(g.ranges(), nav_gaps_of(run.info))).get(pair)
        plot_distance_errors(ax, rows, shaded, methods=methods, time_origin_s=t0, gaps=gaps)
        shade_windows(ax, windows - t0)  # the run's outage windows (--outage), if any

    return Panels(pairs, pairs, stack_layout(opts.style), draw, _time_finish(t0), "pairs")


def _di_errors(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """Paper 000 fig. 8: one panel per pair that has a reference DI."""
    di = run.di[_has(run.di, "di_reference")]
    by_pair = {p: rows for p, rows in groups(di, "pair").items() if opts.keep_pair(p)}
    pairs = sorted(by_pair)
    if not pairs:
        return None
    t0 = run.time_origin_s

    def draw(ax: Axes, i: int) -> None:
        gaps = g.gaps("pairs", lambda: pair_gaps(g.ranges(), nav_gaps_of(run.info))).get(pairs[i])
        plot_di_errors(ax, by_pair[pairs[i]], time_origin_s=t0, gaps=gaps)

    return Panels(pairs, pairs, stack_layout(opts.style), draw, _time_finish(t0), "pairs")


def _platform_rows(
    g: FigureGroups, opts: FigureOptions, methods: Sequence[str], *, error: bool
) -> dict[str, dict[str, pd.DataFrame]]:
    """Each chosen platform's rows per method of ``methods`` (slices; with ``error``: the
    platforms where one of them has a horizontal error, never a mask over every row)."""
    out = {}
    for platform in g.positions():
        if not opts.keep_platform(platform):
            continue
        own = g.methods(platform)
        rows = {m: own[m] for m in methods if m in own and len(own[m])}
        if error:
            rows = {m: r for m, r in rows.items() if bool(r["error_h"].notna().any())}
        if rows:
            out[platform] = rows
    return out


def _position_errors(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """Paper 000 fig. 12: one panel per platform with a horizontal error."""
    methods = position_methods(run)
    by_platform = _platform_rows(g, opts, methods, error=True)
    platforms = sorted(by_platform)
    if not platforms:
        return None
    t0 = run.time_origin_s
    windows = outage_windows_of(run.info)

    def rows_of() -> dict[str, GapSpans]:
        rows = _platform_rows(g, opts, methods, error=False)
        return method_gaps(rows, nav_gaps_of(run.info))

    def draw(ax: Axes, i: int) -> None:
        rows = by_platform[platforms[i]]
        gap = g.gaps("platforms", rows_of).get(platforms[i])
        plot_position_errors(ax, rows, methods=methods, time_origin_s=t0, gaps=gap)
        shade_windows(ax, windows - t0)

    titles = [f"Platform {p}" for p in platforms]
    layout = stack_layout(opts.style)
    return Panels(platforms, titles, layout, draw, _time_finish(t0), "platforms")


def _nlos_convergence(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """Paper 000 fig. 10: one panel per NLOS event."""
    panels = convergence_panels(run, opts)
    if not panels:
        return None

    ranges = g.ranges()

    def draw(ax: Axes, i: int) -> None:
        _, rows, bias = panels[i]
        pair = ranges.get(str(rows["pair"].iloc[0])) if len(rows) else None
        limit = None if pair is None else line_gap_limit_s(pair["time"].to_numpy(float))
        plot_nlos_convergence(ax, rows, reference_bias_m=bias, gap_limit_s=limit)

    titles = [title for title, _, _ in panels]
    scores = [event_score(rows) for _, rows, _ in panels]  # the cap keeps the largest
    layout = grid_layout(1.55, opts.style)
    return Panels(titles, titles, layout, draw, noun="NLOS events", scores=scores)


def _trajectories(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """Tracks in the east-north plane, one panel per moving platform (paper 000 fig. 7):
    start, end and anchors marked, a zoomed inset where the methods overlap."""
    platforms = sorted(p for p in g.positions() if opts.keep_platform(p))
    if not platforms:
        return None
    methods = ("reference", "nav", *position_methods(run))
    anchors = run_anchors(run)

    def draw(ax: Axes, i: int) -> None:
        plot_trajectory(ax, g.methods(platforms[i]), methods=methods, anchors=anchors)

    titles = [f"Platform {p}" for p in platforms]
    return Panels(platforms, titles, grid_layout(2.3, opts.style), draw, noun="platforms")


def _error_cdf(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """CDF of the horizontal error, one panel per platform with one (methods overlaid)."""
    methods = ("nav", *position_methods(run))
    by_platform = _platform_rows(g, opts, methods, error=True)
    platforms = sorted(by_platform)
    if not platforms:
        return None

    def draw(ax: Axes, i: int) -> None:
        plot_error_cdf(ax, by_platform[platforms[i]], methods=methods)

    titles = [f"Platform {p}" for p in platforms]
    return Panels(platforms, titles, grid_layout(2.0, opts.style), draw, noun="platforms")


def _error_track(run: RunTables, opts: FigureOptions, g: FigureGroups) -> Panels | None:
    """The primary method's track coloured by its horizontal error over the reference, one
    panel per platform; one colour scale (0 to the 95th percentile) for all panels."""
    method = track_method(run)
    if method is None:
        return None
    own = _platform_rows(g, opts, [method], error=True)
    platforms = sorted(own)
    if not platforms:
        return None
    errors = [rows[method]["error_h"].to_numpy(dtype=np.float64) for rows in own.values()]
    norm = error_norm(np.concatenate(errors))
    anchors = run_anchors(run)

    def draw(ax: Axes, i: int) -> Any:
        rows = g.methods(platforms[i])
        dots = plot_error_track(ax, rows, method, norm=norm)
        track = rows[method][_has(rows[method], "error_h")].sort_values("time", kind="stable")
        mark_start_end(ax, track["east"].to_numpy(float), track["north"].to_numpy(float))
        mark_anchors(ax, anchors)
        return dots

    def finish(fig: Figure, axes: list[Axes], drawn: list[Any]) -> None:
        dots = [d for d in drawn if d is not None]
        if dots:
            colorbar_below(fig, axes, dots[-1], "Horizontal error (m)")
        legend(fig, axes)

    titles = [f"Platform {p}" for p in platforms]
    layout = grid_layout(2.3, opts.style, colorbar=True)
    return Panels(platforms, titles, layout, draw, finish, "platforms")


BUILDERS: dict[str, Callable[[RunTables, FigureOptions, FigureGroups], Panels | None]] = {
    "distance_errors": _distance_errors,
    "di_errors": _di_errors,
    "position_errors": _position_errors,
    "nlos_convergence": _nlos_convergence,
    "trajectories": _trajectories,
    "error_cdf": _error_cdf,
    "error_track": _error_track,
    "outage_drift": outage_panels,  # runs with [run] outages only (report/outage_figure.py)
    "dr_states": dr_states_panels,  # runs whose fusion has DR states (dr_states_figure.py)
    "consistency": consistency_panels,  # NIS / NEES of the filters (consistency_figure.py)
}
