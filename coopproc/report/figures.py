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
drawn from their min/max envelope (:mod:`coopproc.report.decimate`). The panels of each
figure are built in :mod:`coopproc.report.figure_builders`.

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
from matplotlib.figure import Figure

from coopproc.errors import ConfigError
from coopproc.report.consistency_figure import CONSISTENCY_FIGURE_NAMES
from coopproc.report.dr_states_figure import DR_FIGURE_NAMES
from coopproc.report.figure_builders import BUILDERS, FigureGroups
from coopproc.report.outage_figure import OUTAGE_FIGURE_NAMES
from coopproc.report.page_workers import save_pages
from coopproc.report.pages import FigureOptions, page_ranges, page_stem
from coopproc.report.panel_cap import Capped, cap_panels
from coopproc.report.panels import Panels
from coopproc.report.run_tables import RunTables

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
FIGURE_NAMES: tuple[str, ...] = tuple(
    n
    for n in BUILDERS
    if n not in (*OUTAGE_FIGURE_NAMES, *DR_FIGURE_NAMES, *CONSISTENCY_FIGURE_NAMES)
)


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
    g = FigureGroups(run)
    for name, build in BUILDERS.items():
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
        built = BUILDERS[name](run, opts, FigureGroups(run))
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
    for name in (*FIGURE_NAMES, *OUTAGE_FIGURE_NAMES, *DR_FIGURE_NAMES):
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
