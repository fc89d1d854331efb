"""The paper's figures from a run's tables: one panel per pair, platform or NLOS event.

``make_figures`` builds matplotlib Figures (no pyplot, no global state: the style of
:mod:`coopproc.report.style` is applied with ``rc_context``); ``write_figures`` saves them
as PNG (300 dpi by default), PDF and/or SVG with fixed metadata, so the same run gives the
same files. Figures whose data are missing (no reference, no NLOS estimates, no DI table
rows) are skipped. The methods drawn are the run's (:mod:`coopproc.report.methods`); the
*primary* method (``di`` if the run has it, else its last processed range method) is the
one whose NLOS events are shaded and that gets one convergence panel per event.

| file | content | paper 000 |
|---|---|---|
| ``distance_errors`` | distance error per method over time, NLOS events shaded | fig. 9, 11 |
| ``di_errors`` | DI error of dead reckoning, cooperative positioning, smoothed DI | fig. 8 |
| ``position_errors`` | horizontal position error per method | fig. 12 |
| ``nlos_convergence`` | NLOS estimate after each step of eq. (11) per event | fig. 10 |
| ``trajectories`` | tracks in the east-north plane with the reference | fig. 7 |
| ``error_cdf`` | CDF of the horizontal error per platform, methods overlaid | |
| ``error_track`` | the primary method's track coloured by horizontal error | |
"""

from __future__ import annotations

import math
import string
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.errors import ConfigError
from coopproc.report.evaluation_plots import (
    error_norm,
    plot_error_cdf,
    plot_error_track,
    track_method,
)
from coopproc.report.methods import (
    nlos_methods,
    position_methods,
    primary_method,
    range_methods,
)
from coopproc.report.plots import (
    plot_di_errors,
    plot_distance_errors,
    plot_nlos_convergence,
    plot_position_errors,
    plot_trajectory,
)
from coopproc.report.rundir import RunTables
from coopproc.report.scores import event_bias
from coopproc.report.style import COLUMN_WIDTH_IN, PANEL_HEIGHT_IN, RC, WIDE_WIDTH_IN

__all__ = ["FIGURE_NAMES", "FORMATS", "make_figures", "write_figures"]

FORMATS: tuple[str, ...] = ("png", "pdf", "svg")
#: Metadata that would change from run to run (tool versions, dates) left out.
_METADATA: dict[str, dict[str, Any]] = {
    "png": {"Software": None},
    "pdf": {"Creator": None, "Producer": None, "CreationDate": None},
    "svg": {"Creator": None, "Date": None},
}
#: Most panels stacked in one column; more go into a 3-column grid.
_MAX_STACK = 6


def _label(i: int, text: str) -> str:
    letter = string.ascii_lowercase[i] if i < 26 else str(i + 1)
    return f"({letter}) {text}"


def _stack(n: int) -> tuple[Figure, list[Axes]]:
    """Panels stacked in one column sharing the time axis; a 3-column grid beyond 6."""
    if n > _MAX_STACK:
        return _grid(n, PANEL_HEIGHT_IN, sharex=True)
    fig = Figure(figsize=(COLUMN_WIDTH_IN, 0.55 + PANEL_HEIGHT_IN * n), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _grid(n: int, row_height_in: float, *, sharex: bool = False) -> tuple[Figure, list[Axes]]:
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    width = COLUMN_WIDTH_IN if ncols == 1 else WIDE_WIDTH_IN * (0.67 if ncols == 2 else 1.0)
    fig = Figure(figsize=(width, 0.45 + row_height_in * nrows), layout="constrained")
    grid = fig.subplots(nrows, ncols, squeeze=False, sharex=sharex)
    axes = list(grid.ravel())
    for ax in axes[n:]:
        fig.delaxes(ax)
    return fig, axes[:n]


def _legend(fig: Figure, axes: Sequence[Axes]) -> None:
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


def _time_label(axes: Sequence[Axes], origin_s: float) -> None:
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


def _has(frame: pd.DataFrame, column: str) -> pd.Series:
    return frame[column].notna()


def distance_errors_figure(run: RunTables) -> Figure | None:
    """Paper 000 fig. 9/11: one panel per pair that has a reference distance."""
    ranges = run.ranges[_has(run.ranges, "reference")]
    pairs = sorted(ranges["pair"].unique())
    if not pairs:
        return None
    t0 = run.time_origin_s
    methods = range_methods(run)
    events = run.nlos_events
    primary = primary_method(run)
    if primary is not None and primary in set(events["method"]):
        events = events[events["method"] == primary]
    fig, axes = _stack(len(pairs))
    for i, (ax, pair) in enumerate(zip(axes, pairs, strict=True)):
        plot_distance_errors(
            ax,
            ranges[ranges["pair"] == pair],
            events[events["pair"] == pair],
            methods=methods,
            time_origin_s=t0,
        )
        ax.set_title(_label(i, pair), loc="left")
    _time_label(axes, t0)
    _legend(fig, axes)
    return fig


def di_errors_figure(run: RunTables) -> Figure | None:
    """Paper 000 fig. 8: one panel per pair that has a reference DI."""
    di = run.di[_has(run.di, "di_reference")]
    pairs = sorted(di["pair"].unique())
    if not pairs:
        return None
    t0 = run.time_origin_s
    fig, axes = _stack(len(pairs))
    for i, (ax, pair) in enumerate(zip(axes, pairs, strict=True)):
        plot_di_errors(ax, di[di["pair"] == pair], time_origin_s=t0)
        ax.set_title(_label(i, pair), loc="left")
    _time_label(axes, t0)
    _legend(fig, axes)
    return fig


def position_errors_figure(run: RunTables) -> Figure | None:
    """Paper 000 fig. 12: one panel per platform with a horizontal error."""
    methods = position_methods(run)
    pos = run.positions[_has(run.positions, "error_h") & run.positions["method"].isin(methods)]
    platforms = sorted(pos["platform"].unique())
    if not platforms:
        return None
    t0 = run.time_origin_s
    fig, axes = _stack(len(platforms))
    for i, (ax, platform) in enumerate(zip(axes, platforms, strict=True)):
        rows = pos[pos["platform"] == platform]
        plot_position_errors(ax, rows, methods=methods, time_origin_s=t0)
        ax.set_title(_label(i, f"Platform {platform}"), loc="left")
    _time_label(axes, t0)
    _legend(fig, axes)
    return fig


def convergence_panels(run: RunTables) -> list[tuple[str, pd.DataFrame, float | None]]:
    """(title, estimate rows of every method, reference bias) per event of the primary method.

    The primary method is the run's (:func:`~coopproc.report.methods.primary_method`) if
    it has estimates, else the first NLOS method with estimates, else the first by name.
    Events of other methods of the same pair join the panel whose time span they overlap
    (spans widened by one step spacing).
    """
    est = run.nlos_estimates
    if est is None or not len(est):
        return []
    have = {str(m) for m in est["method"].unique()}
    preferred = [m for m in (primary_method(run), *nlos_methods(run)) if m in have]
    primary = preferred[0] if preferred else sorted(have)[0]
    spans = {
        key: (float(g["time"].min()), float(g["time"].max()), g)
        for key, g in est.groupby(["pair", "method", "event"], sort=True)
    }
    panels = []
    for (pair, method, event), (lo, hi, rows) in spans.items():
        if method != primary:
            continue
        dt = float(np.median(np.diff(np.sort(rows["time"].to_numpy())))) if len(rows) > 1 else 1.0
        parts = [rows]
        for (p2, m2, _), (lo2, hi2, rows2) in spans.items():
            if p2 == pair and m2 != primary and lo2 <= hi + dt and hi2 >= lo - dt:
                parts.append(rows2)
        bias = _event_reference_bias(run, str(pair), str(method), lo)
        panels.append(
            (f"{pair}, event {event} (t = {lo - run.time_origin_s:.0f} s)", pd.concat(parts), bias)
        )
    return panels


def _event_reference_bias(run: RunTables, pair: str, method: str, first_s: float) -> float | None:
    events = run.nlos_events[
        (run.nlos_events["pair"] == pair) & (run.nlos_events["method"] == method)
    ]
    if not len(events):
        return None
    nearest = events.iloc[int(np.argmin(np.abs(events["start"].to_numpy(float) - first_s)))]
    pair_ranges = run.ranges[run.ranges["pair"] == pair]
    bias, n = event_bias(pair_ranges, float(nearest["start"]), float(nearest["end"]))
    return bias if n else None


def nlos_convergence_figure(run: RunTables) -> Figure | None:
    """Paper 000 fig. 10: one panel per NLOS event."""
    panels = convergence_panels(run)
    if not panels:
        return None
    fig, axes = _grid(len(panels), 1.55)
    for i, (ax, (title, rows, bias)) in enumerate(zip(axes, panels, strict=True)):
        plot_nlos_convergence(ax, rows, reference_bias_m=bias)
        ax.set_title(_label(i, title), loc="left")
    _legend(fig, axes)
    return fig


def trajectories_figure(run: RunTables) -> Figure | None:
    """Tracks in the east-north plane, one panel per moving platform (paper 000 fig. 7)."""
    platforms = sorted(run.positions["platform"].unique())
    if not platforms:
        return None
    methods = ("reference", "nav", *position_methods(run))
    fig, axes = _grid(len(platforms), 2.3)
    for i, (ax, platform) in enumerate(zip(axes, platforms, strict=True)):
        rows = run.positions[run.positions["platform"] == platform]
        plot_trajectory(ax, rows, methods=methods)
        ax.set_title(_label(i, f"Platform {platform}"), loc="left")
    _legend(fig, axes)
    return fig


def error_cdf_figure(run: RunTables) -> Figure | None:
    """CDF of the horizontal error, one panel per platform with one (methods overlaid)."""
    methods = ("nav", *position_methods(run))
    pos = run.positions[_has(run.positions, "error_h") & run.positions["method"].isin(methods)]
    platforms = sorted(pos["platform"].unique())
    if not platforms:
        return None
    fig, axes = _grid(len(platforms), 2.0)
    for i, (ax, platform) in enumerate(zip(axes, platforms, strict=True)):
        plot_error_cdf(ax, pos[pos["platform"] == platform], methods=methods)
        ax.set_title(_label(i, f"Platform {platform}"), loc="left")
    _legend(fig, axes)
    return fig


def error_track_figure(run: RunTables) -> Figure | None:
    """The primary method's track coloured by its horizontal error over the reference, one
    panel per platform; one colour scale (0 to the 95th percentile) for all panels."""
    method = track_method(run)
    pos = run.positions
    own = pos[(pos["method"] == method) & _has(pos, "error_h")]
    platforms = sorted(own["platform"].unique())
    if method is None or not platforms:
        return None
    norm = error_norm(own["error_h"].to_numpy(dtype=np.float64))
    fig, axes = _grid(len(platforms), 2.3)
    dots = None
    for i, (ax, platform) in enumerate(zip(axes, platforms, strict=True)):
        drawn = plot_error_track(ax, pos[pos["platform"] == platform], method, norm=norm)
        dots = drawn if drawn is not None else dots
        ax.set_title(_label(i, f"Platform {platform}"), loc="left")
    if dots is not None:
        fig.colorbar(
            dots,
            ax=axes,
            location="bottom",
            shrink=0.5,
            aspect=40,
            extend="max",
            label="Horizontal error (m)",
        )
    _legend(fig, axes)
    return fig


_BUILDERS: dict[str, Callable[[RunTables], Figure | None]] = {
    "distance_errors": distance_errors_figure,
    "di_errors": di_errors_figure,
    "position_errors": position_errors_figure,
    "nlos_convergence": nlos_convergence_figure,
    "trajectories": trajectories_figure,
    "error_cdf": error_cdf_figure,
    "error_track": error_track_figure,
}
FIGURE_NAMES: tuple[str, ...] = tuple(_BUILDERS)


def make_figures(run: RunTables) -> dict[str, Figure]:
    """Every figure the run's data allow, by name (see the module table)."""
    out = {}
    with mpl.rc_context(RC):
        for name, build in _BUILDERS.items():
            fig = build(run)
            if fig is not None:
                out[name] = fig
    return out


def write_figures(
    run: RunTables, fig_dir: Path, *, formats: Sequence[str] = ("png",), dpi: int = 300
) -> list[Path]:
    """Save every figure as ``fig_dir/<name>.<format>``; returns the paths written, in order."""
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise ConfigError(f"unknown figure format {bad[0]!r}; expected one of {', '.join(FORMATS)}")
    fig_dir = Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    written = []
    with mpl.rc_context(RC):
        for name, fig in make_figures(run).items():
            for fmt in formats:
                path = fig_dir / f"{name}.{fmt}"
                fig.savefig(path, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
                written.append(path)
    return written
