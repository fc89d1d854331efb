"""Figures of ``coopproc report OUT --stochastic --plots`` (paper 002 fig. 6, Allan plots).

- ``uwb_acf``: the autocorrelation of the LOS range residuals against the lag, one panel
  per pair (and ``all``), with 1/e and the +-1.96/sqrt(n) band of white noise;
- ``uwb_pdf``: the histogram (density) of the LOS range residuals per pair, with the
  fitted Gaussian N(mean, std) and the normality test's p-value;
- ``allan``: the overlapping Allan deviation of each IMU axis, gyro (deg/h) and
  accelerometer (mg) per platform, with the white-noise line N / sqrt(tau) of the
  noisiest axis, the bias instability level, and each minimum marked.

Panels in a grid of up to 3 columns; the same fixed metadata as
:mod:`coopproc.report.figures`, so the same run gives the same files. A
:class:`~coopproc.report.pages.FigureOptions` (``--pairs`` / ``--platforms`` / ``--style``)
keeps the panels of the chosen pairs (the pooled ``all`` panel only without a choice of
pairs or platforms) and IMU platforms, in the chosen figure style.
"""

from __future__ import annotations

import dataclasses
import io
import math
from collections.abc import Sequence

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.errors import ConfigError
from coopproc.report.allan import FLICKER_FACTOR, G_MPS2, ImuAllan
from coopproc.report.figures import _METADATA, FORMATS
from coopproc.report.pages import FigureOptions
from coopproc.report.pages import panel_label as _label
from coopproc.report.panels import grid as _grid
from coopproc.report.panels import legend as _legend
from coopproc.report.stochastic import PairStochastics, StochasticReport
from coopproc.report.stochastic_format import stochastic_html
from coopproc.report.style import DEFAULT_STYLE, FigureStyle

__all__ = [
    "STOCHASTIC_FIGURE_NAMES",
    "allan_figure",
    "plot_acf",
    "plot_allan",
    "plot_residual_pdf",
    "render_stochastic_figures",
    "select_stochastic",
    "stochastic_figures",
    "stochastic_section",
    "uwb_acf_figure",
    "uwb_pdf_figure",
]

STOCHASTIC_FIGURE_NAMES: tuple[str, ...] = ("uwb_acf", "uwb_pdf", "allan")
_AXIS_COLORS = {"x": "#1f77b4", "y": "#2ca02c", "z": "#d62728"}
_DATA = "#1f77b4"
_FIT = "#d62728"


def plot_acf(ax: Axes, pair: PairStochastics) -> Axes:
    """The slotted ACF of one pair's LOS residuals against the lag (s)."""
    ok = np.isfinite(pair.acf)
    n = pair.stats.n
    ax.plot(
        pair.acf_lag_s[ok],
        pair.acf[ok],
        color=_DATA,
        marker=".",
        markersize=2,
        gid="acf",
        label="ACF",
    )
    band = 1.96 / math.sqrt(n)
    ax.axhspan(-band, band, color="0.5", alpha=0.15, linewidth=0, label="white 95 %")
    ax.axhline(math.exp(-1.0), color=_FIT, linestyle="--", linewidth=0.7, gid="e_fold", label="1/e")
    ax.axhline(0.0, color="0.3", linewidth=0.5, zorder=0)
    ax.set_ylim(min(-0.3, float(np.nanmin(pair.acf)) - 0.05), 1.05)
    # the decay, not 200 lags of noise: 20 intervals or 4 correlation times
    tau = max(pair.stats.gm_tau_s, float(np.nan_to_num(pair.stats.corr_time_s)))
    shown = max(20.0 * pair.stats.interval_s, 4.0 * tau)
    ax.set_xlim(-0.02 * shown, min(shown, float(pair.acf_lag_s[-1])) * 1.02)
    ax.set_ylabel("ACF")
    return ax


def plot_residual_pdf(ax: Axes, pair: PairStochastics) -> Axes:
    """Histogram (density) of one pair's LOS residuals and the Gaussian N(mean, std)."""
    r = pair.residual_m
    bins = int(min(60, max(10, round(math.sqrt(r.size)))))
    ax.hist(r, bins=bins, density=True, color=_DATA, alpha=0.55, gid="histogram", label="residuals")
    mean, std = float(np.mean(r)), pair.stats.std
    x = np.linspace(float(r.min()), float(r.max()), 200)
    pdf = np.exp(-0.5 * ((x - mean) / std) ** 2) / (std * math.sqrt(2.0 * math.pi))
    ax.plot(x, pdf, color=_FIT, gid="gaussian", label="Gaussian fit")
    p = pair.stats.normal_p
    text = f"std {std:.3f} m" + (f"\np = {p:.2g}" if np.isfinite(p) else "")
    ax.text(0.98, 0.95, text, transform=ax.transAxes, ha="right", va="top", fontsize=6.5)
    ax.set_ylabel("Density (1/m)")
    return ax


def _uwb_figure(
    pairs: Sequence[PairStochastics], kind: str, style: FigureStyle = DEFAULT_STYLE
) -> Figure | None:
    if not pairs:
        return None
    fig, axes = _grid(len(pairs), 1.6, style=style)
    ncols = min(len(pairs), style.max_columns)
    for i, (ax, pair) in enumerate(zip(axes, pairs, strict=True)):
        if kind == "acf":
            plot_acf(ax, pair)
            title = f"{pair.pair}: rho1 {pair.stats.rho1:.2f}"
        else:
            plot_residual_pdf(ax, pair)
            title = pair.pair + (" (about each pair's mean)" if pair.pair == "all" else "")
        ax.set_title(_label(i, title), loc="left")
        if i >= len(pairs) - ncols:  # the bottom panel of each column
            ax.set_xlabel("Lag (s)" if kind == "acf" else "LOS range residual (m)")
    _legend(fig, axes)
    return fig


def uwb_acf_figure(report: StochasticReport, style: FigureStyle = DEFAULT_STYLE) -> Figure | None:
    """One ACF panel per pair."""
    return _uwb_figure(report.uwb, "acf", style)


def uwb_pdf_figure(report: StochasticReport, style: FigureStyle = DEFAULT_STYLE) -> Figure | None:
    """One histogram panel per pair."""
    return _uwb_figure(report.uwb, "pdf", style)


def plot_allan(ax: Axes, res: ImuAllan, sensor: str) -> Axes:
    """Allan deviation of the three axes of one sensor, in deg/h (gyro) or mg (accel)."""
    scale = math.degrees(1.0) * 3600.0 if sensor == "gyro" else 1e3 / G_MPS2
    for a in (a for a in res.axes if a.sensor == sensor):
        ax.loglog(
            a.tau_s,
            a.adev * scale,
            color=_AXIS_COLORS[a.axis],
            gid=f"{sensor}_{a.axis}",
            label=f"{a.axis} axis",
        )
        ax.plot(
            [a.tau_min_s],
            [a.minimum * scale],
            "o",
            color=_AXIS_COLORS[a.axis],
            markersize=3,
            gid=f"{sensor}_{a.axis}_min",
        )
    worst = res.worst(sensor)
    tau = worst.tau_s
    ax.loglog(
        tau,
        worst.white / np.sqrt(tau) * scale,
        color="0.3",
        linestyle=":",
        linewidth=0.7,
        gid=f"{sensor}_white",
        label="N / sqrt(tau)",
    )
    b = res.worst_bias(sensor)
    ax.axhline(
        b.minimum / FLICKER_FACTOR * scale,
        color="0.3",
        linestyle="--",
        linewidth=0.6,
        gid=f"{sensor}_bias",
        label="bias instability",
    )
    ax.set_ylabel("Allan dev. (deg/h)" if sensor == "gyro" else "Allan dev. (mg)")
    return ax


def allan_figure(report: StochasticReport, style: FigureStyle = DEFAULT_STYLE) -> Figure | None:
    """Per platform: gyro and accelerometer Allan deviation, side by side."""
    results = report.imu
    if not results:
        return None
    width = style.wide_width_in * (0.8 if style.max_columns > 2 else 1.0)
    fig = Figure(figsize=(width, 0.5 + 2.1 * len(results)), layout="constrained")
    axes = list(fig.subplots(len(results), 2, squeeze=False).ravel())
    for i, res in enumerate(results):  # a row per platform: gyro, accelerometer
        for j, sensor in enumerate(("gyro", "accel")):
            ax = axes[2 * i + j]
            plot_allan(ax, res, sensor)
            name = "gyro" if sensor == "gyro" else "accelerometer"
            ax.set_title(_label(2 * i + j, f"{res.platform} {name}"), loc="left")
            ax.set_xlabel("Averaging time tau (s)")
    _legend(fig, axes)
    return fig


def select_stochastic(report: StochasticReport, options: FigureOptions) -> StochasticReport:
    """The pairs and IMU platforms ``options`` keeps (the pooled ``all`` pair only when
    nothing is chosen: it pools pairs that were not chosen)."""
    if not options.selects:
        return report
    return dataclasses.replace(
        report,
        uwb=tuple(p for p in report.uwb if p.pair != "all" and options.keep_pair(p.pair)),
        imu=tuple(r for r in report.imu if options.keep_platform(r.platform)),
    )


def stochastic_figures(
    report: StochasticReport, options: FigureOptions | None = None
) -> dict[str, Figure]:
    """Every figure the report's data allow, by name (:data:`STOCHASTIC_FIGURE_NAMES`),
    of the pairs and platforms ``options`` keeps, in its style."""
    opts = options or FigureOptions()
    report = select_stochastic(report, opts)
    out = {}
    with mpl.rc_context(opts.style.rc):
        for name, build in (
            ("uwb_acf", uwb_acf_figure),
            ("uwb_pdf", uwb_pdf_figure),
            ("allan", allan_figure),
        ):
            fig = build(report, opts.style)
            if fig is not None:
                out[name] = fig
    return out


def render_stochastic_figures(
    report: StochasticReport,
    *,
    formats: Sequence[str] = ("png",),
    dpi: int = 300,
    options: FigureOptions | None = None,
) -> dict[str, bytes]:
    """Every stochastic figure in every format, as ``{"<name>.<format>": bytes}`` (in
    order), for the caller to write (atomically) into ``OUT/figures``."""
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise ConfigError(f"unknown figure format {bad[0]!r}; expected one of {', '.join(FORMATS)}")
    out: dict[str, bytes] = {}
    with mpl.rc_context((options or FigureOptions()).style.rc):
        for name, fig in stochastic_figures(report, options).items():
            for fmt in formats:
                buf = io.BytesIO()
                fig.savefig(buf, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
                out[f"{name}.{fmt}"] = buf.getvalue()
    return out


def stochastic_section(report: StochasticReport) -> str:
    """The "Stochastic analysis" section of report.html, its figures rendered at 150 dpi
    (from the report itself, so the page never shows figures of an earlier analysis)."""
    pngs = render_stochastic_figures(report, formats=("png",), dpi=150)
    return stochastic_html(report, {k.removesuffix(".png"): v for k, v in pngs.items()})
