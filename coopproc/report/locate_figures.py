"""Figures of ``coopproc locate`` (paper 004 figures 8-11, 13): trajectories, errors over
time, and the AACOPF particle cloud at a few epochs.

Plot functions draw on the axes they are given; :func:`write_locate_figures` makes the
figures and saves them. They use the figure styles of ``coopproc run``
(:mod:`coopproc.report.style`: ``--style default|single-column|double-column`` sizes and
fonts, the reference's line, the start / end markers of
:mod:`coopproc.report.trajectory_plots`), one legend above the panels
(:func:`~coopproc.report.panels.legend`) and the same reproducible PNG/PDF/SVG files
(300 dpi, no dates or versions in them). The auxiliaries are drawn as grey dashed tracks
with a diamond at their start and end. The backend is the caller's choice (the CLI picks
Agg).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.estimation.locate_result import LocateResult
from coopproc.report.panels import grid, legend, stack
from coopproc.report.style import DEFAULT_STYLE, FigureStyle, method_style
from coopproc.report.trajectory_plots import mark_start_end

__all__ = [
    "plot_locate_errors",
    "plot_locate_trajectories",
    "plot_particle_cloud",
    "write_locate_figures",
]

_COLORS = {"aacopf": "#d62728", "pf": "#1f77b4", "ekf": "#2ca02c"}
_LABELS = {"aacopf": "AACOPF", "pf": "PF", "ekf": "EKF"}
#: Auxiliaries: grey dashed tracks, a diamond at start and end (``Axes.plot`` keywords).
AUX_STYLE: dict[str, Any] = {
    "color": "0.55",
    "linestyle": "--",
    "linewidth": 0.8,
    "marker": "D",
    "markersize": 3.5,
    "markerfacecolor": "0.55",
    "markeredgecolor": "0.25",
    "markeredgewidth": 0.4,
    "markevery": [0, -1],
}
_METADATA: dict[str, dict[str, None]] = {
    "png": {"Software": None},
    "pdf": {"Creator": None, "Producer": None, "CreationDate": None},
    "svg": {"Creator": None, "Date": None},
}


def plot_locate_trajectories(ax: Axes, result: LocateResult) -> Axes:
    """Auxiliaries (dashed, diamonds at start and end), the target's reference, every
    method's estimated track (ENU, m) and the target's start and end (legend: Start, End)."""
    inputs = result.inputs
    for j, aux in enumerate(inputs.aux):
        en = inputs.aux_en_m[:, j]
        ax.plot(en[:, 0], en[:, 1], gid=f"aux_{aux}", label=f"Auxiliary {aux}", **AUX_STYLE)
    ref_style = method_style("reference")
    if result.reference_en_m is not None:
        ref = result.reference_en_m
        ax.plot(
            ref[:, 0],
            ref[:, 1],
            gid="reference",
            color=ref_style.color,
            linewidth=ref_style.linewidth,
            label=f"{inputs.target} reference",
        )
    for method, track in result.tracks.items():
        ax.plot(
            track.east_m,
            track.north_m,
            gid=method,
            color=_COLORS.get(method),
            linewidth=0.9,
            label=_LABELS.get(method, method),
        )
    if result.reference_en_m is not None:
        mark_start_end(ax, result.reference_en_m[:, 0], result.reference_en_m[:, 1])
    elif result.tracks:
        track = next(iter(result.tracks.values()))
        mark_start_end(ax, np.asarray(track.east_m), np.asarray(track.north_m))
    ax.set_xlabel("East (m)")
    ax.set_ylabel("North (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"Target {inputs.target}", loc="left")
    return ax


def plot_locate_errors(ax_pos: Axes, ax_az: Axes, result: LocateResult) -> tuple[Axes, Axes]:
    """Horizontal error and initial-azimuth error over time, per method."""
    t0 = float(result.inputs.time_s[0])
    table = result.table
    for method in result.tracks:
        rows = table[table["method"] == method]
        t = rows["time"].to_numpy() - t0
        ax_pos.plot(t, rows["error_h"].to_numpy(), color=_COLORS.get(method), lw=0.9,
                    label=_LABELS.get(method, method), gid=method)  # fmt: skip
        az = result.azimuth_error_track_deg(method)
        if az is not None:
            ax_az.plot(t, az, color=_COLORS.get(method), lw=0.9, label=_LABELS.get(method, method))
    start = result.observability.observable_from
    for ax in (ax_pos, ax_az):
        if start is not None:
            ax.axvline(
                float(result.inputs.time_s[start]) - t0,
                color="0.5",
                ls=":",
                lw=1.0,
                label="Observable from",
            )
    ax_pos.set_yscale("log")
    ax_pos.set_ylabel("Horizontal error (m)")
    ax_az.set_ylabel("Initial azimuth error (deg)")
    ax_az.set_xlabel(f"Time since t0 = {t0:.1f} (s)" if t0 else "Time (s)")
    return ax_pos, ax_az


def plot_particle_cloud(ax: Axes, result: LocateResult, index: int) -> Axes:
    """The AACOPF particle cloud (a seeded subsample) at snapshot ``index``."""
    track = result.tracks["aacopf"]
    time_s, pts = track.snapshots[index]
    k = int(np.searchsorted(result.inputs.time_s, time_s))
    ax.plot(pts[:, 0], pts[:, 1], ".", ms=1.0, color=_COLORS["aacopf"], alpha=0.4,
            label="Particles", rasterized=True)  # fmt: skip
    aux = result.inputs.aux_en_m[k]
    ax.plot(aux[:, 0], aux[:, 1], "D", color="0.55", mec="0.25", mew=0.4, ms=4,
            label="Auxiliary")  # fmt: skip
    if result.reference_en_m is not None and np.all(np.isfinite(result.reference_en_m[k])):
        ref = result.reference_en_m[k]
        ax.plot(ref[0], ref[1], "*", color="black", ms=8, label="Reference")
    ax.plot(track.east_m[k], track.north_m[k], "x", color="#1f77b4", ms=6, label="Estimate")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("East (m)")
    ax.set_ylabel("North (m)")
    ax.set_title(f"t = {time_s - float(result.inputs.time_s[0]):.1f} s", loc="left")
    return ax


def write_locate_figures(
    result: LocateResult,
    fig_dir: Path,
    formats: tuple[str, ...] = ("png",),
    *,
    style: FigureStyle = DEFAULT_STYLE,
    dpi: int = 300,
) -> list[Path]:
    """Save the locate figures into ``fig_dir`` in ``style``; returns the files written."""
    fig_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def save(fig: Figure, name: str) -> None:
        for fmt in formats:
            path = fig_dir / f"{name}.{fmt}"
            fig.savefig(path, format=fmt, dpi=dpi, metadata=_METADATA.get(fmt))
            written.append(path)

    with mpl.rc_context(style.rc):
        width = style.column_width_in
        fig = Figure(figsize=(width, 0.75 * width + 0.9), layout="constrained")
        ax = fig.add_subplot()
        plot_locate_trajectories(ax, result)
        legend(fig, [ax])
        save(fig, "locate_trajectories")
        fig, (ax_pos, ax_az) = stack(2, style)
        plot_locate_errors(ax_pos, ax_az, result)
        legend(fig, [ax_pos, ax_az])
        save(fig, "locate_errors")
        if "aacopf" in result.tracks and result.tracks["aacopf"].snapshots:
            count = len(result.tracks["aacopf"].snapshots)
            fig, axes = grid(count, 2.0, style=style)
            for i, ax in enumerate(axes):
                plot_particle_cloud(ax, result, i)
            legend(fig, axes)
            save(fig, "locate_particles")
    return written
