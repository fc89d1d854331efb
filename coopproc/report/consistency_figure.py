"""``consistency``: does each filter's claimed uncertainty match its errors over time?
(:mod:`coopproc.report.consistency`)

One panel per fusion method (NIS of its range innovations, all pairs in time order) and
per INS method and quantity (NEES of velocity, of attitude): the mean NIS (NEES divided
by its 3 degrees of freedom) over consecutive windows of :data:`WINDOW` epochs, on a log
scale, against the 95 % band a consistent filter's window mean stays in
(``chi2_{0.025, 0.975}(W dof) / (W dof)``) and the line at 1. Above the band:
overconfident (sigmas too small); below: conservative.

A figure of :mod:`coopproc.report.figures` (registered there); drawn only for a run with
``range_weights.csv`` or INS states with sigmas.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.distributions import chi2_ppf
from coopproc.model import FloatArray
from coopproc.report.consistency import nees_series, nis_series
from coopproc.report.methods import position_methods
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels, stack_layout, time_label
from coopproc.report.run_tables import RunTables
from coopproc.report.table_specs import method_label

__all__ = ["CONSISTENCY_FIGURE_NAMES", "WINDOW", "consistency_panels", "window_means"]

CONSISTENCY_FIGURE_NAMES: tuple[str, ...] = ("consistency",)
#: Epochs per window mean: 50 ranges are under a minute of 3 pairs at 1 Hz, and the 95 %
#: band of a 50-range mean of chi2(1) is 0.65 .. 1.43, narrow enough to see a factor 2.
WINDOW = 50


def window_means(t: FloatArray, x: FloatArray, window: int) -> tuple[FloatArray, FloatArray]:
    """Mean time and mean value of consecutive windows of ``window`` finite epochs."""
    ok = np.isfinite(x)
    t, x = t[ok], x[ok]
    k = x.size // window
    if not k:
        return np.empty(0), np.empty(0)
    shape = (k, window)
    return t[: k * window].reshape(shape).mean(axis=1), x[: k * window].reshape(shape).mean(axis=1)


def consistency_panels(run: RunTables, opts: FigureOptions, _groups: Any = None) -> Panels | None:
    """The panels of ``consistency`` (None without innovations or INS sigmas)."""
    series: dict[str, tuple[str, int, list[tuple[FloatArray, FloatArray]]]] = {}
    for pair, method, t, nis in nis_series(run.range_weights):
        if opts.keep_pair(pair):
            key = f"nis:{method}"
            series.setdefault(
                key, (f"{method_label(method)} fusion: NIS of range innovations", 1, [])
            )
            series[key][2].append((t, nis))
    words = {"vel": "velocity", "att": "attitude"}
    for platform, method, kind, t, nees in nees_series(run.states):
        if opts.keep_platform(platform):
            key = f"nees_{kind}:{method}"
            title = f"{method_label(method)}: NEES of {words[kind]} / 3"
            series.setdefault(key, (title, 3, []))
            series[key][2].append((t, nees / 3.0))
    if not series:
        return None
    methods = position_methods(run)  # the run's order: observed, rn, di, ...
    rank = {m: i for i, m in enumerate(methods)}
    keys = sorted(
        series, key=lambda k: (k.split(":")[0] != "nis", rank.get(k.split(":", 1)[1], 99), k)
    )
    t0 = run.time_origin_s

    def draw(ax: Axes, i: int) -> None:
        _title, dof, parts = series[keys[i]]
        t = np.concatenate([p[0] for p in parts])
        x = np.concatenate([p[1] for p in parts])
        order = np.argsort(t, kind="stable")
        tm, xm = window_means(t[order] - t0, x[order], WINDOW)
        n = WINDOW * dof
        lo, hi = chi2_ppf([0.025, 0.975], n) / n
        ax.axhspan(lo, hi, color="0.85", label=f"95 % band (consistent, {WINDOW} epochs)")
        ax.axhline(1.0, color="0.4", linewidth=0.8)
        if tm.size:
            ax.plot(tm, np.clip(xm, 1e-4, None), ".-", markersize=3, linewidth=0.8)
            above = float(np.mean(xm > hi))
            ax.text(
                0.01,
                0.95,
                f"{100 * above:.0f} % of windows above the band",
                transform=ax.transAxes,
                va="top",
                fontsize="small",
            )
        ax.set_yscale("log")
        ax.set_ylabel("mean NIS / NEES per dof")

    def finish(fig: Figure, axes: list[Axes], drawn: list[Any]) -> None:
        time_label(axes, t0)

    titles = [series[k][0] for k in keys]
    return Panels(keys, titles, stack_layout(opts.style), draw, finish, "filters")
