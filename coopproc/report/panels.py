"""Pages of panels: the layout shared by the figures of :mod:`coopproc.report.figures`.

A figure kind is a list of panels (one per pair, platform or NLOS event) and a function
drawing panel ``i`` on an Axes (:class:`Panels`); :meth:`Panels.page` draws the panels of
one page (:func:`~coopproc.report.pages.page_ranges`) with labels that run on across
pages. Up to 6 panels are stacked in one column sharing the time axis; more go into a
3-column grid.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.report.pages import panel_label
from coopproc.report.style import DEFAULT_STYLE, PANEL_HEIGHT_IN, FigureStyle
from coopproc.report.title_fit import legend_room, wrap_titles

__all__ = [
    "Layout",
    "Panels",
    "by_method",
    "colorbar_below",
    "grid",
    "grid_layout",
    "groups",
    "legend",
    "stack",
    "stack_layout",
    "time_label",
    "time_sorted",
]

#: Most panels stacked in one column; more go into a 3-column grid.
_MAX_STACK = 6
#: Margins of a grid of more than 6 panels, in inches: left, right, top (legend), bottom
#: (time label, colour bar), between rows (title, tick labels), between columns (y label).
_FIXED_MARGINS_IN = (0.58, 0.08, 0.62, 0.5, 0.42, 0.6)
#: More room between rows whose panels each have an x label, and below for a colour bar.
_XLABEL_IN = 0.2
_COLORBAR_IN = 0.5

Layout = Callable[[int], tuple[Figure, list[Axes]]]


def stack(n: int, style: FigureStyle = DEFAULT_STYLE) -> tuple[Figure, list[Axes]]:
    """Panels stacked in one column (``style.column_width_in`` wide) sharing the time
    axis; a grid beyond 6."""
    if n > _MAX_STACK:
        return grid(n, PANEL_HEIGHT_IN, sharex=True, style=style)
    size = (style.column_width_in, 0.55 + PANEL_HEIGHT_IN * n)
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def stack_layout(style: FigureStyle = DEFAULT_STYLE) -> Layout:
    """:func:`stack` in ``style``."""
    return lambda n: stack(n, style)


def grid_layout(
    row_height_in: float,
    style: FigureStyle = DEFAULT_STYLE,
    *,
    colorbar: bool = False,
) -> Layout:
    """:func:`grid` of rows ``row_height_in`` high in ``style``."""
    return lambda n: grid(n, row_height_in, colorbar=colorbar, style=style)


def grid(
    n: int,
    row_height_in: float,
    *,
    sharex: bool = False,
    colorbar: bool = False,
    style: FigureStyle = DEFAULT_STYLE,
) -> tuple[Figure, list[Axes]]:
    """``n`` panels in up to ``style.max_columns`` columns (3 by default, full text
    width), rows of ``row_height_in`` (times ``style.row_scale``).

    Up to 6 panels the constrained layout fits labels and legend; beyond, fixed margins
    in inches (:data:`_FIXED_MARGINS_IN`) do, since the constrained layout solver costs
    about 0.1 s a panel; ``colorbar`` keeps room below the panels for one
    (:func:`colorbar_below`), ``sharex`` leaves the x tick labels to the bottom row."""
    ncols = min(n, style.max_columns)
    nrows = math.ceil(n / ncols)
    width = style.grid_width_in(ncols)
    row_height_in *= style.row_scale
    if n <= _MAX_STACK:
        fig = Figure(figsize=(width, 0.45 + row_height_in * nrows), layout="constrained")
    else:
        left, right, top, bottom, hgap, wgap = _FIXED_MARGINS_IN
        hgap += 0.0 if sharex else _XLABEL_IN  # every panel has its own x label
        bottom += _COLORBAR_IN if colorbar else 0.0
        height = top + bottom + row_height_in * nrows
        axes_w = (width - left - right - (ncols - 1) * wgap) / ncols
        axes_h = (height - top - bottom - (nrows - 1) * hgap) / nrows
        fig = Figure(figsize=(width, height))
        fig.subplots_adjust(
            left=left / width,
            right=1.0 - right / width,
            top=1.0 - top / height,
            bottom=bottom / height,
            wspace=wgap / axes_w,
            hspace=hgap / axes_h,
        )
    panels = fig.subplots(nrows, ncols, squeeze=False, sharex=sharex)
    axes = list(panels.ravel())
    for ax in axes[n:]:
        fig.delaxes(ax)
    return fig, axes[:n]


def colorbar_below(fig: Figure, axes: Sequence[Axes], mappable: Any, label: str) -> None:
    """A horizontal colour bar under the panels, half the figure wide (constrained layout:
    made room for by the solver; fixed layout: in the room :func:`grid` kept)."""
    if fig.get_layout_engine() is not None:
        fig.colorbar(
            mappable,
            ax=list(axes),
            location="bottom",
            shrink=0.5,
            aspect=40,
            extend="max",
            label=label,
        )
        return
    height = fig.get_figheight()
    cax = fig.add_axes((0.25, 0.42 / height, 0.5, 0.07 / height))
    fig.colorbar(mappable, cax=cax, orientation="horizontal", extend="max", label=label)


def legend(fig: Figure, axes: Sequence[Axes]) -> None:
    """One legend above the panels with every label drawn, each once."""
    seen: dict[str, Any] = {}
    for ax in axes:
        handles, labels = ax.get_legend_handles_labels()
        for handle, label in zip(handles, labels, strict=True):
            seen.setdefault(label, handle)
    if seen:
        # Three entries a row where they fit the figure width, else two.
        width_chars = fig.get_figwidth() * 13
        ncols = min(len(seen), 3)
        if sum(len(k) + 6 for k in list(seen)[:ncols]) > width_chars:
            ncols = 2
        fig.legend(list(seen.values()), list(seen), loc="outside upper center", ncols=ncols)


def time_label(axes: Sequence[Axes], origin_s: float) -> None:
    """Label the time axis of the bottom panel of every column."""
    text = f"Time since t0 = {origin_s:.1f} (s)" if origin_s else "Time (s)"
    bottom: dict[int, Axes] = {}
    for ax in axes:
        spec = ax.get_subplotspec()
        column = spec.colspan.start if spec is not None else 0
        bottom[column] = ax
    for ax in bottom.values():
        ax.set_xlabel(text)
        ax.xaxis.set_tick_params(labelbottom=True)


def groups(frame: pd.DataFrame, column: str) -> dict[str, pd.DataFrame]:
    """The rows of ``frame`` per value of ``column`` (one pass; no per-value comparison
    of a text column), by the value as text."""
    if not len(frame):
        return {}
    values = frame[column]
    if isinstance(values.dtype, pd.CategoricalDtype):  # positions.csv's text columns
        runs = _category_runs(frame, values)
        if runs is not None:
            return runs
    codes, uniques = pd.factorize(values, sort=False)
    if codes.min() >= 0 and bool(np.all(np.diff(codes) >= 0)):  # each value's rows together
        starts = [0, *(np.flatnonzero(np.diff(codes)) + 1).tolist(), len(frame)]
        # row slices: views of the table, not a copy of it per value (a day: GBs)
        bounds = zip(uniques, starts[:-1], starts[1:], strict=True)
        return {str(k): frame.iloc[a:b] for k, a, b in bounds}
    return {str(k): g for k, g in frame.groupby(column, sort=False, observed=True)}


def _category_runs(frame: pd.DataFrame, values: pd.Series) -> dict[str, pd.DataFrame] | None:
    """:func:`groups` of a categorical column whose values each lie in one run of rows,
    from its codes (a factorization of a day's 38 M rows was 2.5 s of the figures, issue
    11); None when a value is missing or its rows are not together."""
    codes = values.cat.codes.to_numpy()
    if codes.min() < 0:
        return None
    starts = np.concatenate(([0], np.flatnonzero(codes[1:] != codes[:-1]) + 1))
    first = codes[starts]
    if np.unique(first).shape[0] != first.shape[0]:  # a value in two runs
        return None
    names = values.cat.categories
    bounds = zip(first.tolist(), starts.tolist(), [*starts[1:].tolist(), len(frame)], strict=True)
    return {str(names[c]): frame.iloc[a:b] for c, a, b in bounds}


def by_method(rows: pd.DataFrame | Mapping[str, pd.DataFrame]) -> Mapping[str, pd.DataFrame]:
    """One platform's rows per method: ``rows`` itself when already grouped (e.g.
    :meth:`~coopproc.report.figure_builders.FigureGroups.methods`), else :func:`groups`."""
    return rows if isinstance(rows, Mapping) else groups(rows, "method")


def time_sorted(rows: pd.DataFrame) -> pd.DataFrame:
    """``rows`` in time order (a stable sort), as they are when already sorted: no copy."""
    if rows["time"].is_monotonic_increasing:
        return rows
    return rows.sort_values("time", kind="stable")


def _legend_only(fig: Figure, axes: list[Axes], drawn: list[Any]) -> None:
    legend(fig, axes)


@dataclass(frozen=True)
class Panels:
    """The panels of one figure kind: ``keys`` (pair, platform or event) with ``titles``;
    ``draw(ax, i)`` draws panel ``i`` and returns what a ``finish`` step may need (e.g.
    the dots for a colour bar); ``finish(fig, axes, drawn)`` adds legend, axis labels.
    ``noun`` names the keys ("pairs", "platforms", "NLOS events"); ``scores`` (one per
    panel, higher first; None: the first are kept) rank the panels when a cap leaves
    some out (:mod:`coopproc.report.panel_cap`)."""

    keys: Sequence[str]
    titles: Sequence[str]
    layout: Layout
    draw: Callable[[Axes, int], Any]
    finish: Callable[[Figure, list[Axes], list[Any]], None] = _legend_only
    noun: str = "panels"
    scores: Sequence[float] | None = None

    def subset(self, indices: Sequence[int]) -> Panels:
        """The panels at ``indices`` (in that order), numbered from 0 again."""
        at = list(indices)
        draw = self.draw
        return Panels(
            keys=[self.keys[i] for i in at],
            titles=[self.titles[i] for i in at],
            layout=self.layout,
            draw=lambda ax, j: draw(ax, at[j]),
            finish=self.finish,
            noun=self.noun,
            scores=None if self.scores is None else [self.scores[i] for i in at],
        )

    def page(self, indices: Sequence[int]) -> Figure:
        """The figure of the panels at ``indices`` (labels from their index)."""
        fig, axes = self.layout(len(indices))
        drawn = []
        titles = []
        for ax, i in zip(axes, indices, strict=True):
            drawn.append(self.draw(ax, i))
            titles.append(ax.set_title(panel_label(i, self.titles[i]), loc="left"))
        self.finish(fig, axes, drawn)
        # titles wider than their column on two lines (measured with the legend and labels
        # in place), then a fixed-margin page taller where the legend needs it
        wrap_titles(fig, axes, titles)
        legend_room(fig, titles)
        return fig
