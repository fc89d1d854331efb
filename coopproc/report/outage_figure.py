"""``outage_drift``: horizontal error against time since the outage started (paper 003
Fig. 9-10), one panel per platform, one colour per method (its own navigation ``nav``
included), one line per outage window of the run (``outages.csv``).

A figure of :mod:`coopproc.report.figures` (registered there); drawn only for a run with
outage windows (``coopproc run --outage T0:T1`` or ``[run] outages``).
"""

from __future__ import annotations

from typing import Any

from matplotlib.axes import Axes

from coopproc.report.outage import drift_curves
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels, grid_layout, stack_layout
from coopproc.report.rundir import RunTables
from coopproc.report.style import method_style

__all__ = ["OUTAGE_FIGURE_NAMES", "outage_panels"]

#: The figures of a run with UWB outage windows only; like the stochastic ones, not among
#: :data:`coopproc.report.figures.FIGURE_NAMES` (the figures every run draws).
OUTAGE_FIGURE_NAMES: tuple[str, ...] = ("outage_drift",)


def outage_panels(run: RunTables, opts: FigureOptions, _groups: Any = None) -> Panels | None:
    """The panels of ``outage_drift`` (None without outages.csv or positions inside)."""
    if run.outages is None or not len(run.outages):
        return None
    curves = {}
    for platform in sorted(str(p) for p in run.outages["platform"].unique()):
        if not opts.keep_platform(platform):
            continue
        drawn = drift_curves(run.positions, run.outages, platform)
        if drawn:
            curves[platform] = drawn
    platforms = sorted(curves)
    if not platforms:
        return None

    def draw(ax: Axes, i: int) -> None:
        for method, lines in curves[platforms[i]].items():
            style = method_style(method).kwargs()
            for k, (t, err) in enumerate(lines):
                ax.plot(t, err, **(style if k == 0 else {**style, "label": None}))
        ax.set_xlabel("Time since the outage started (s)")
        ax.set_ylabel("Horizontal error (m)")
        ax.set_xlim(left=0.0)
        ax.set_ylim(bottom=0.0)

    titles = [f"Platform {p}" for p in platforms]
    layout = stack_layout(opts.style) if len(platforms) == 1 else grid_layout(2.0, opts.style)
    return Panels(platforms, titles, layout, draw, noun="platforms")
