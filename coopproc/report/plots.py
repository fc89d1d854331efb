"""Axes-level plots of the output tables: each draws one panel on the Axes it is given.

Every function takes the rows of ONE pair / platform / event, draws on ``ax`` with the
styles of :mod:`coopproc.report.style` and returns ``ax``. Each line's ``gid`` is its
series key (``observed``, ``rn``, ``di``, ``di_dr``, ``reference``...), so tests and users
can read the plotted data back. Times are shown relative to ``time_origin_s``. The methods
drawn are the given ``methods`` (the run's, :mod:`coopproc.report.methods`), by default
those found in the rows themselves.

Nothing is drawn across a gap: a time-series line breaks (a NaN is inserted) where
consecutive samples are further apart than the figures' gap rule
(:func:`~coopproc.report.gaps.line_gap_limit_s`: 2.5 times the series' typical step,
the longer of the 90th percentile and the time-weighted 75th percentile of its steps), and the
spans without data given as ``gaps`` (UWB outages, no reference:
:class:`~coopproc.report.gaps.GapSpans`) are shaded under the data. A line of more than
:func:`~coopproc.report.decimate.panel_points` samples (two per pixel column of the panel,
at most :data:`~coopproc.report.style.MAX_LINE_POINTS`) is drawn from its min/max envelope
(:mod:`coopproc.report.decimate`: spikes and gaps stay visible, every break is kept).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.ticker import MaxNLocator

from coopproc.report.decimate import decimate, panel_points
from coopproc.report.gaps import GapSpans, break_gaps, shade_gaps
from coopproc.report.methods import position_methods_of, range_methods_of
from coopproc.report.panels import by_method as rows_by_method
from coopproc.report.panels import time_sorted
from coopproc.report.style import DI_STYLES, NLOS_SPAN, method_style
from coopproc.report.trajectory_plots import plot_trajectory  # moved; re-exported

__all__ = [
    "plot_di_errors",
    "plot_distance_errors",
    "plot_nlos_convergence",
    "plot_position_errors",
    "plot_trajectory",
]


def _values(frame: pd.DataFrame, column: str) -> np.ndarray:
    return frame[column].to_numpy(dtype=np.float64, na_value=np.nan)


def _break_gaps(ax: Axes, time_s: np.ndarray, *series: np.ndarray) -> tuple[np.ndarray, ...]:
    """``time_s`` and ``series`` with a NaN inserted in every gap of ``time_s`` (sorted),
    so that a line plot draws nothing across it, then decimated to what ``ax``'s pixels
    show (:func:`~coopproc.report.decimate.panel_points`; every NaN kept)."""
    time_s, *rest = break_gaps(time_s, *series)
    return decimate(time_s, *rest, max_points=panel_points(ax))


def plot_distance_errors(
    ax: Axes,
    pair_ranges: pd.DataFrame,
    pair_events: pd.DataFrame | None = None,
    *,
    methods: Sequence[str] | None = None,
    time_origin_s: float = 0.0,
    gaps: GapSpans | None = None,
) -> Axes:
    """Distance error (method - reference) over time per method, NLOS events shaded.

    Paper 000 fig. 9 and 11. Epochs without a reference are left out; ``pair_events``
    (rows of ``nlos_events`` for this pair, any method) are shaded from start to end,
    ``gaps`` (the pair's outages and no-reference spans, run times) too.
    ``methods`` default: the range method columns of ``pair_ranges``.
    """
    if methods is None:
        methods = range_methods_of(pair_ranges)
    rows = time_sorted(pair_ranges)
    t = _values(rows, "time") - time_origin_s
    ref = _values(rows, "reference")
    for method in methods:
        if method not in rows.columns:
            continue
        err = _values(rows, method) - ref
        keep = np.isfinite(err)
        x, y = _break_gaps(ax, t[keep], err[keep])
        ax.plot(x, y, gid=method, **method_style(method).kwargs(t[keep].size))
    if pair_events is not None:
        for i, (start, end) in enumerate(
            zip(_values(pair_events, "start"), _values(pair_events, "end"), strict=True)
        ):
            ax.axvspan(
                start - time_origin_s,
                end - time_origin_s,
                gid="nlos_span",
                label="NLOS detected" if i == 0 else "_nolegend_",
                **NLOS_SPAN,
            )
    if gaps is not None:  # after the lines: listed after them in the legend
        shade_gaps(ax, gaps.shifted(time_origin_s))
    ax.axhline(0.0, color="0.3", linewidth=0.5, zorder=0)
    ax.set_ylabel("Distance error (m)")
    return ax


def plot_di_errors(
    ax: Axes,
    pair_di: pd.DataFrame,
    *,
    time_origin_s: float = 0.0,
    gaps: GapSpans | None = None,
) -> Axes:
    """DI error against the reference DI: dead reckoning, cooperative positioning, smoothed.

    Paper 000 fig. 8 (the distance increments of eq. (1) and the filter of eq. (4)-(7));
    ``gaps`` (the pair's outages and no-reference spans, run times) shaded.
    """
    rows = time_sorted(pair_di)
    t = _values(rows, "time") - time_origin_s
    ref = _values(rows, "di_reference")
    for column, style in DI_STYLES.items():
        err = _values(rows, column) - ref
        keep = np.isfinite(err)
        x, y = _break_gaps(ax, t[keep], err[keep])
        ax.plot(x, y, gid=column, **style.kwargs(t[keep].size))
    if gaps is not None:
        shade_gaps(ax, gaps.shifted(time_origin_s))
    ax.axhline(0.0, color="0.3", linewidth=0.5, zorder=0)
    ax.set_ylabel("DI error (m)")
    return ax


def plot_position_errors(
    ax: Axes,
    platform_positions: pd.DataFrame | Mapping[str, pd.DataFrame],
    *,
    methods: Sequence[str] | None = None,
    time_origin_s: float = 0.0,
    gaps: GapSpans | None = None,
) -> Axes:
    """Horizontal position error over time per method (paper 000 fig. 12).

    ``platform_positions``: the platform's rows, or its rows per method; ``methods``
    default: the position methods of the rows (not ``nav`` / ``reference``); ``gaps``
    (the platform's outages and no-reference spans, run times) shaded.
    """
    by_method = rows_by_method(platform_positions)
    if methods is None:
        methods = position_methods_of(pd.DataFrame({"method": list(by_method)}))
    for method in methods:
        if method not in by_method:
            continue
        rows = time_sorted(by_method[method])
        err = _values(rows, "error_h")
        keep = np.isfinite(err)
        if not keep.any():
            continue
        t = _values(rows, "time") - time_origin_s
        x, y = _break_gaps(ax, t[keep], err[keep])
        ax.plot(x, y, gid=method, **method_style(method).kwargs(t[keep].size))
    if gaps is not None:
        shade_gaps(ax, gaps.shifted(time_origin_s))
    ax.set_ylabel("Horizontal error (m)")
    ax.set_ylim(bottom=0.0)
    return ax


def plot_nlos_convergence(
    ax: Axes,
    event_estimates: pd.DataFrame,
    *,
    reference_bias_m: float | None = None,
    gap_limit_s: float | None = None,
) -> Axes:
    """NLOS estimate after each step of eq. (11) per method (paper 000 fig. 10).

    ``event_estimates``: rows of ``nlos_estimates`` for one event (one or several methods);
    ``reference_bias_m``: the mean of observed - reference over the event, drawn dotted;
    ``gap_limit_s``: the line breaks between steps further apart in ``time`` (an outage
    inside the event), e.g. the pair's :func:`~coopproc.report.gaps.line_gap_limit_s`.
    """
    for method, rows in event_estimates.groupby("method", sort=False):
        rows = rows.sort_values("step", kind="stable")
        style = method_style(str(method))
        steps, estimates = _values(rows, "step"), _values(rows, "estimate")
        if gap_limit_s is not None and "time" in rows.columns:
            _, steps, estimates = break_gaps(
                _values(rows, "time"), steps, estimates, limit_s=gap_limit_s
            )
        ax.plot(
            steps,
            estimates,
            gid=str(method),
            marker="o",
            markersize=2.2,
            **style.kwargs(),
        )
    if reference_bias_m is not None and np.isfinite(reference_bias_m):
        ax.axhline(
            reference_bias_m,
            gid="reference_bias",
            label="Reference bias",
            color="black",
            linestyle=":",
            linewidth=0.9,
        )
        # keep the reference line off the frame: the y range spans data and bias, padded
        values = np.append(_values(event_estimates, "estimate"), reference_bias_m)
        values = values[np.isfinite(values)]
        pad = 0.1 * max(float(np.ptp(values)), 0.01)
        ax.set_ylim(float(values.min()) - pad, float(values.max()) + pad)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    steps = np.unique(_values(event_estimates, "step"))
    steps = steps[np.isfinite(steps)]
    if steps.size == 1:  # one step (e.g. an RN-only event): whole steps around it
        ax.set_xlim(float(steps[0]) - 1.0, float(steps[0]) + 1.0)
    ax.set_xlabel("Estimation step")
    ax.set_ylabel("NLOS estimate (m)")
    return ax
