"""The paper's figures from a run's tables: one panel per pair, platform or NLOS event.

``make_figures`` builds matplotlib Figures (no pyplot, no global state: the style of
:mod:`coopproc.report.style` is applied with ``rc_context``); ``write_figures`` saves them
as PNG (300 dpi by default), PDF and/or SVG with fixed metadata, so the same run gives the
same files. Figures whose data are missing (no reference, no NLOS estimates, no DI table
rows) are skipped. The methods drawn are the run's (:mod:`coopproc.report.methods`); the
*primary* method (``di`` if the run has it, else its last processed range method) is the
one whose NLOS events are shaded and that gets one convergence panel per event.

:class:`~coopproc.report.pages.FigureOptions` chooses the pairs, platforms and most panels
per page (further pages ``name_2.png``..., :mod:`coopproc.report.pages`); long series are
drawn from their min/max envelope (:mod:`coopproc.report.decimate`).

| file | content | paper 000 |
|---|---|---|
| ``distance_errors`` | distance error per method over time, NLOS events shaded | fig. 9, 11 |
| ``di_errors`` | DI error of dead reckoning, cooperative positioning, smoothed DI | fig. 8 |
| ``position_errors`` | horizontal position error per method | fig. 12 |
| ``nlos_convergence`` | NLOS estimate after each step of eq. (11) per event | fig. 10 |
| ``trajectories`` | tracks in the east-north plane with the reference | fig. 7 |
| ``error_cdf`` | CDF of the horizontal error per platform, methods overlaid | |
| ``error_track`` | the primary method's track coloured by horizontal error | |
| ``outage_drift`` | error against time since each UWB outage started | 003 fig. 9-10 |
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.errors import ConfigError
from coopproc.report.convergence import convergence_panels
from coopproc.report.evaluation_plots import (
    error_norm,
    plot_error_cdf,
    plot_error_track,
    track_method,
)
from coopproc.report.gaps import GapSpans, line_gap_limit_s, pair_gaps, platform_gaps
from coopproc.report.methods import position_methods, primary_method, range_methods
from coopproc.report.outage_figure import OUTAGE_FIGURE_NAMES, outage_panels
from coopproc.report.page_workers import save_pages
from coopproc.report.pages import FigureOptions, page_ranges, page_stem
from coopproc.report.panel_cap import Capped, cap_panels, event_score
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
from coopproc.report.rundir import RunTables
from coopproc.report.trajectory_plots import (
    mark_anchors,
    mark_start_end,
    plot_trajectory,
    run_anchors,
)

__all__ = [
    "FIGURE_NAMES",
    "FORMATS",
    "FigurePage",
    "figure_pages",
    "make_figures",
    "write_figures",
]

FORMATS: tuple[str, ...] = ("png", "pdf", "svg")
#: Metadata that would change from run to run (tool versions, dates) left out.
_METADATA: dict[str, dict[str, Any]] = {
    "png": {"Software": None},
    "pdf": {"Creator": None, "Producer": None, "CreationDate": None},
    "svg": {"Creator": None, "Date": None},
}
#: PNG text chunk with the keys of a page's panels, separated by ``PANEL_SEPARATOR``.
PANELS_KEY = "Panels"
PANEL_SEPARATOR = "; "


def _has(frame: pd.DataFrame, column: str) -> pd.Series:
    return frame[column].notna()


class _Groups:
    """The run's rows per pair / platform, grouped once and shared by the figures."""

    def __init__(self, run: RunTables) -> None:
        self.run = run
        self._cache: dict[str, dict[str, pd.DataFrame]] = {}
        self._gaps: dict[str, dict[str, GapSpans]] = {}

    def positions(self) -> dict[str, pd.DataFrame]:
        if "positions" not in self._cache:
            self._cache["positions"] = groups(self.run.positions, "platform")
        return self._cache["positions"]

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


def _distance_errors(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
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

    def draw(ax: Axes, i: int) -> None:
        pair = pairs[i]
        rows, shaded = by_pair[pair], events_by_pair.get(pair, no_events)
        gaps = g.gaps("pairs", lambda: pair_gaps(g.ranges())).get(pair)
        plot_distance_errors(ax, rows, shaded, methods=methods, time_origin_s=t0, gaps=gaps)

    return Panels(pairs, pairs, stack_layout(opts.style), draw, _time_finish(t0), "pairs")


def _di_errors(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
    """Paper 000 fig. 8: one panel per pair that has a reference DI."""
    di = run.di[_has(run.di, "di_reference")]
    by_pair = {p: rows for p, rows in groups(di, "pair").items() if opts.keep_pair(p)}
    pairs = sorted(by_pair)
    if not pairs:
        return None
    t0 = run.time_origin_s

    def draw(ax: Axes, i: int) -> None:
        gaps = g.gaps("pairs", lambda: pair_gaps(g.ranges())).get(pairs[i])
        plot_di_errors(ax, by_pair[pairs[i]], time_origin_s=t0, gaps=gaps)

    return Panels(pairs, pairs, stack_layout(opts.style), draw, _time_finish(t0), "pairs")


def _platform_rows(
    g: _Groups, opts: FigureOptions, methods: Sequence[str], *, error: bool
) -> dict[str, pd.DataFrame]:
    """Each chosen platform's rows of ``methods`` (with a horizontal error if ``error``)."""
    out = {}
    for platform, rows in g.positions().items():
        if not opts.keep_platform(platform):
            continue
        keep = rows["method"].isin(list(methods))
        if error:
            keep &= _has(rows, "error_h")
        if keep.any():
            out[platform] = rows[keep]
    return out


def _position_errors(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
    """Paper 000 fig. 12: one panel per platform with a horizontal error."""
    methods = position_methods(run)
    by_platform = _platform_rows(g, opts, methods, error=True)
    platforms = sorted(by_platform)
    if not platforms:
        return None
    t0 = run.time_origin_s
    rows_of = lambda: platform_gaps(_platform_rows(g, opts, methods, error=False))  # noqa: E731

    def draw(ax: Axes, i: int) -> None:
        rows = by_platform[platforms[i]]
        gap = g.gaps("platforms", rows_of).get(platforms[i])
        plot_position_errors(ax, rows, methods=methods, time_origin_s=t0, gaps=gap)

    titles = [f"Platform {p}" for p in platforms]
    layout = stack_layout(opts.style)
    return Panels(platforms, titles, layout, draw, _time_finish(t0), "platforms")


def _nlos_convergence(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
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


def _trajectories(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
    """Tracks in the east-north plane, one panel per moving platform (paper 000 fig. 7):
    start, end and anchors marked, a zoomed inset where the methods overlap."""
    by_platform = {p: rows for p, rows in g.positions().items() if opts.keep_platform(p)}
    platforms = sorted(by_platform)
    if not platforms:
        return None
    methods = ("reference", "nav", *position_methods(run))
    anchors = run_anchors(run)

    def draw(ax: Axes, i: int) -> None:
        plot_trajectory(ax, by_platform[platforms[i]], methods=methods, anchors=anchors)

    titles = [f"Platform {p}" for p in platforms]
    return Panels(platforms, titles, grid_layout(2.3, opts.style), draw, noun="platforms")


def _error_cdf(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
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


def _error_track(run: RunTables, opts: FigureOptions, g: _Groups) -> Panels | None:
    """The primary method's track coloured by its horizontal error over the reference, one
    panel per platform; one colour scale (0 to the 95th percentile) for all panels."""
    method = track_method(run)
    if method is None:
        return None
    own = _platform_rows(g, opts, [method], error=True)
    platforms = sorted(own)
    if not platforms:
        return None
    errors = [rows["error_h"].to_numpy(dtype=np.float64) for rows in own.values()]
    norm = error_norm(np.concatenate(errors))
    by_platform = g.positions()
    anchors = run_anchors(run)

    def draw(ax: Axes, i: int) -> Any:
        rows = by_platform[platforms[i]]
        dots = plot_error_track(ax, rows, method, norm=norm)
        track = own[platforms[i]].sort_values("time", kind="stable")
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


_BUILDERS: dict[str, Callable[[RunTables, FigureOptions, _Groups], Panels | None]] = {
    "distance_errors": _distance_errors,
    "di_errors": _di_errors,
    "position_errors": _position_errors,
    "nlos_convergence": _nlos_convergence,
    "trajectories": _trajectories,
    "error_cdf": _error_cdf,
    "error_track": _error_track,
    "outage_drift": outage_panels,  # runs with [run] outages only (report/outage_figure.py)
}
FIGURE_NAMES: tuple[str, ...] = tuple(n for n in _BUILDERS if n not in OUTAGE_FIGURE_NAMES)


@dataclass(frozen=True)
class FigurePage:
    """One page of a figure: file ``stem`` (``name``, ``name_2``...), the keys of its
    panels and where it stands (page ``index`` of ``count``, ``total`` panels drawn);
    ``capped``: what the figure's cap left out (:mod:`coopproc.report.panel_cap`)."""

    name: str
    stem: str
    index: int
    count: int
    keys: tuple[str, ...]
    first: int
    total: int
    draw: Callable[[], Figure]
    capped: Capped | None = None


def figure_pages(run: RunTables, options: FigureOptions | None = None) -> Iterator[FigurePage]:
    """Every page the run's data allow (within the cap of ``options.max_pages``), in
    figure order; nothing is drawn until a page's ``draw()`` is called (it applies the
    style of ``options``: ``rc_context(style.rc)``)."""
    opts = options or FigureOptions()
    g = _Groups(run)
    for name, build in _BUILDERS.items():
        built = build(run, opts, g)
        if built is None:
            continue
        panels, capped = cap_panels(name, built, run, opts)
        pages = page_ranges(len(panels.keys), opts.max_panels)
        for index, at in enumerate(pages):
            yield FigurePage(
                name=name,
                stem=page_stem(name, index),
                index=index,
                count=len(pages),
                keys=tuple(panels.keys[i] for i in at),
                first=at.start,
                total=len(panels.keys),
                draw=lambda p=panels, at=at: _draw_styled(p, at, opts),  # type: ignore[misc]
                capped=capped,
            )


def _draw_styled(panels: Panels, at: Sequence[int], opts: FigureOptions) -> Figure:
    """A page drawn in the fonts of ``opts.style`` whatever the caller's rc settings."""
    with mpl.rc_context(opts.style.rc):
        return panels.page(at)


def _first_page(name: str) -> Callable[..., Figure | None]:
    def first(run: RunTables, options: FigureOptions | None = None) -> Figure | None:
        opts = options or FigureOptions()
        built = _BUILDERS[name](run, opts, _Groups(run))
        if built is None:
            return None
        panels, _ = cap_panels(name, built, run, opts)
        return _draw_styled(panels, range(min(len(panels.keys), opts.max_panels)), opts)

    first.__doc__ = f"The first page of ``{name}`` (None without data)."
    return first


distance_errors_figure = _first_page("distance_errors")
di_errors_figure = _first_page("di_errors")
position_errors_figure = _first_page("position_errors")
nlos_convergence_figure = _first_page("nlos_convergence")
trajectories_figure = _first_page("trajectories")
error_cdf_figure = _first_page("error_cdf")
error_track_figure = _first_page("error_track")


def make_figures(run: RunTables, options: FigureOptions | None = None) -> dict[str, Figure]:
    """Every page the run's data allow, by file stem (see the module table)."""
    style = (options or FigureOptions()).style
    with mpl.rc_context(style.rc):
        return {page.stem: page.draw() for page in figure_pages(run, options)}


def _stale_pages(fig_dir: Path, fmt: str, keep: set[str]) -> list[Path]:
    """Further pages of our figures left by an earlier call (``name_<n>.fmt``)."""
    out = []
    for name in (*FIGURE_NAMES, *OUTAGE_FIGURE_NAMES):
        for path in fig_dir.glob(f"{name}_*.{fmt}"):
            suffix = path.stem[len(name) + 1 :]
            if suffix.isdigit() and path.stem not in keep:
                out.append(path)
    return out


def write_figures(
    run: RunTables,
    fig_dir: Path,
    *,
    formats: Sequence[str] = ("png",),
    dpi: int = 300,
    options: FigureOptions | None = None,
    notes: list[str] | None = None,
    workers: int | None = None,
    pages: Sequence[FigurePage] | None = None,
) -> list[Path]:
    """Save every page as ``fig_dir/<stem>.<format>`` (one page in memory at a time per
    process) and remove further pages an earlier call left; returns the paths written, in
    order. ``notes``: appended with one sentence per figure the page cap shortened.
    ``workers``: processes drawing pages (None: one per CPU, at most 4; 1: this one;
    :mod:`coopproc.report.page_workers`), the files the same either way. ``pages``: those
    of ``figure_pages(run, options)`` if the caller listed them (e.g. for report.html)."""
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise ConfigError(f"unknown figure format {bad[0]!r}; expected one of {', '.join(FORMATS)}")
    fig_dir = Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    style = (options or FigureOptions()).style

    def save(page: FigurePage) -> list[Path]:
        fig, out = page.draw(), []
        for fmt in formats:
            path = fig_dir / f"{page.stem}.{fmt}"
            meta = dict(_METADATA[fmt])
            if fmt == "png":
                meta[PANELS_KEY] = PANEL_SEPARATOR.join(page.keys)
            fig.savefig(path, format=fmt, dpi=dpi, metadata=meta)
            out.append(path)
        return out

    with mpl.rc_context(style.rc):
        if pages is None:  # the panels built here, shared by the workers
            pages = list(figure_pages(run, options))
        notes_of = [p.capped.note() for p in pages if p.capped is not None and p.index == 0]
        written = save_pages(pages, save, workers=workers, cost=lambda p: len(p.keys))
    if notes is not None:
        notes.extend(notes_of)
    stems = {p.stem for p in written}
    for fmt in FORMATS:
        for path in _stale_pages(fig_dir, fmt, stems):
            path.unlink()
    return written
