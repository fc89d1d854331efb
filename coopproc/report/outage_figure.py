"""``outage_drift``: horizontal error against time since the outage started (paper 003
Fig. 9-10), one panel per platform, one colour per method (its own navigation ``nav``
included), one line per outage window of the run (``outages.csv``). The windows' lines
of a method share its colour, so each window has its own marker (:data:`WINDOW_MARKERS`)
on every fifth sample and at the line's end, and a legend entry with its span
("Window 2: 50.0-60.0 s"): two windows no longer look alike.

A figure of :mod:`coopproc.report.figures` (registered there); drawn only for a run with
outage windows (``coopproc run --outage T0:T1`` or ``[run] outages``).
"""

from __future__ import annotations

from typing import Any

from matplotlib.axes import Axes

from coopproc.report.outage import drift_curves
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels, grid_layout, stack_layout
from coopproc.report.run_tables import RunTables
from coopproc.report.style import method_style

__all__ = ["OUTAGE_FIGURE_NAMES", "WINDOW_MARKERS", "outage_panels"]

#: The markers of windows 1, 2, ... (repeating beyond six).
WINDOW_MARKERS: tuple[str, ...] = ("o", "s", "^", "D", "v", "P")

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

    origin = run.time_origin_s
    spans = {
        int(w): f"Window {int(w)}: {a - origin:.1f}-{b - origin:.1f} s"
        for w, a, b in run.outages.drop_duplicates("window")[["window", "start", "end"]].itertuples(
            index=False
        )
    }

    def marker(window: int) -> str:
        return WINDOW_MARKERS[(window - 1) % len(WINDOW_MARKERS)]

    def draw(ax: Axes, i: int) -> None:
        seen: set[int] = set()
        for method, lines in curves[platforms[i]].items():
            style = method_style(method).kwargs()
            for k, (window, t, err) in enumerate(lines):
                every = sorted({*range(0, t.shape[0], 5), t.shape[0] - 1})
                ax.plot(
                    t, err, **(style if k == 0 else {**style, "label": None}),
                    marker=marker(window), markersize=3.0, markevery=every,
                )  # fmt: skip
                seen.add(window)
        for window in sorted(seen):  # the windows' legend entries: the marker alone
            ax.plot(
                [], [], color="0.3", linestyle="none", marker=marker(window), markersize=3.0,
                label=spans.get(window, f"Window {window}"),
            )  # fmt: skip
        ax.set_xlabel("Time since the outage started (s)")
        ax.set_ylabel("Horizontal error (m)")
        ax.set_xlim(left=0.0)
        ax.set_ylim(bottom=0.0)

    titles = [f"Platform {p}" for p in platforms]
    layout = stack_layout(opts.style) if len(platforms) == 1 else grid_layout(2.0, opts.style)
    return Panels(platforms, titles, layout, draw, noun="platforms")
