"""Figures of ``coopproc locate`` (paper 004 figures 8-11, 13): trajectories, errors over
time, and the AACOPF particle cloud at a few epochs.

Plot functions draw on the axes they are given; :func:`write_locate_figures` makes the
figures and saves them. The backend is the caller's choice (the CLI picks Agg).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.stages.particle import LocateResult

__all__ = [
    "plot_locate_errors",
    "plot_locate_trajectories",
    "plot_particle_cloud",
    "write_locate_figures",
]

_COLORS = {"aacopf": "tab:red", "pf": "tab:blue", "ekf": "tab:green"}
_LABELS = {"aacopf": "AACOPF", "pf": "PF", "ekf": "EKF"}


def plot_locate_trajectories(ax: Axes, result: LocateResult) -> Axes:
    """Auxiliaries, the target's reference and every method's estimated track (ENU, m)."""
    inputs = result.inputs
    for j, aux in enumerate(inputs.aux):
        en = inputs.aux_en_m[:, j]
        ax.plot(en[:, 0], en[:, 1], color="0.6", lw=1.0, ls="--", label=f"auxiliary {aux}")
        ax.plot(en[0, 0], en[0, 1], "o", color="0.4", ms=4)
    if result.reference_en_m is not None:
        ref = result.reference_en_m
        ax.plot(ref[:, 0], ref[:, 1], color="black", lw=1.5, label=f"{inputs.target} reference")
    for method, track in result.tracks.items():
        ax.plot(
            track.east_m,
            track.north_m,
            color=_COLORS.get(method),
            lw=1.0,
            label=_LABELS.get(method, method),
        )
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize="small")
    ax.set_title(f"target {inputs.target}: estimated trajectories")
    return ax


def plot_locate_errors(ax_pos: Axes, ax_az: Axes, result: LocateResult) -> tuple[Axes, Axes]:
    """Horizontal error and initial-azimuth error over time, per method."""
    t0 = float(result.inputs.time_s[0])
    table = result.table
    for method in result.tracks:
        rows = table[table["method"] == method]
        t = rows["time"].to_numpy() - t0
        ax_pos.plot(t, rows["error_h"].to_numpy(), color=_COLORS.get(method), lw=1.0,
                    label=_LABELS.get(method, method))  # fmt: skip
        az = result.azimuth_error_track_deg(method)
        if az is not None:
            ax_az.plot(t, az, color=_COLORS.get(method), lw=1.0, label=_LABELS.get(method, method))
    start = result.observability.observable_from
    for ax in (ax_pos, ax_az):
        if start is not None:
            ax.axvline(
                float(result.inputs.time_s[start]) - t0,
                color="0.5",
                ls=":",
                lw=1.0,
                label="observable from",
            )
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    ax_pos.set_yscale("log")
    ax_pos.set_ylabel("horizontal error (m)")
    ax_az.set_ylabel("initial azimuth error (deg)")
    ax_az.set_xlabel(f"time since t0 = {t0:.1f} s (s)")
    return ax_pos, ax_az


def plot_particle_cloud(ax: Axes, result: LocateResult, index: int) -> Axes:
    """The AACOPF particle cloud (a seeded subsample) at snapshot ``index``."""
    track = result.tracks["aacopf"]
    time_s, pts = track.snapshots[index]
    k = int(np.searchsorted(result.inputs.time_s, time_s))
    ax.plot(pts[:, 0], pts[:, 1], ".", ms=1.0, color="tab:red", alpha=0.4, label="particles")
    aux = result.inputs.aux_en_m[k]
    ax.plot(aux[:, 0], aux[:, 1], "s", color="0.3", ms=5, label="auxiliaries")
    if result.reference_en_m is not None and np.all(np.isfinite(result.reference_en_m[k])):
        ref = result.reference_en_m[k]
        ax.plot(ref[0], ref[1], "*", color="black", ms=10, label="reference")
    ax.plot(track.east_m[k], track.north_m[k], "x", color="tab:blue", ms=8, label="estimate")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"t = {time_s - float(result.inputs.time_s[0]):.1f} s", fontsize="small")
    return ax


def write_locate_figures(
    result: LocateResult, fig_dir: Path, formats: tuple[str, ...] = ("png",)
) -> list[Path]:
    """Save the locate figures into ``fig_dir``; returns the files written."""
    fig_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def save(fig: Figure, name: str) -> None:
        for fmt in formats:
            path = fig_dir / f"{name}.{fmt}"
            fig.savefig(path, dpi=120, metadata={"Software": None} if fmt == "png" else None)
            written.append(path)

    fig = Figure(figsize=(7, 6), layout="constrained")
    plot_locate_trajectories(fig.add_subplot(), result)
    save(fig, "locate_trajectories")
    fig = Figure(figsize=(8, 6), layout="constrained")
    ax_pos, ax_az = fig.subplots(2, 1, sharex=True)
    plot_locate_errors(ax_pos, ax_az, result)
    save(fig, "locate_errors")
    if "aacopf" in result.tracks and result.tracks["aacopf"].snapshots:
        count = len(result.tracks["aacopf"].snapshots)
        fig = Figure(figsize=(4 * count, 4.2), layout="constrained")
        axes = fig.subplots(1, count, squeeze=False)[0]
        for i, ax in enumerate(axes):
            plot_particle_cloud(ax, result, i)
        axes[0].legend(fontsize="x-small")
        fig.suptitle("AACOPF particle cloud")
        save(fig, "locate_particles")
    return written
