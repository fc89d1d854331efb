"""The stochastic analysis as text: tables (terminal, CSV, Markdown, LaTeX, HTML), the
``session.toml`` snippets to paste, and the section of ``report.html``.

Three tables: the UWB range residuals per pair (:mod:`coopproc.report.stochastic`), the
gyro and the accelerometer Allan figures per platform and axis
(:mod:`coopproc.report.allan`). CSV output is one block per table headed by a ``# title``
line, like the other tables of ``coopproc report``; the machine-readable numbers are in
``OUT/stochastic.csv`` and ``OUT/allan.csv``.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from coopproc.report.allan import allan_frame, imu_toml
from coopproc.report.latex_layout import (
    Grid,
    LatexWidth,
    number_cell,
    render_grid,
    tex_escape,
    text_cell,
)
from coopproc.report.stochastic import PairStochastics, StochasticReport

__all__ = ["STOCHASTIC_CAPTIONS", "format_stochastic", "stochastic_html", "uwb_toml"]


@dataclass(frozen=True)
class _Col:
    key: str
    header: str
    decimals: int = 4  # -1: text


@dataclass(frozen=True)
class _Table:
    key: str
    title: str
    cols: tuple[_Col, ...]
    rows: tuple[Mapping[str, Any], ...]


_UWB_COLS = (
    _Col("pair", "Pair", -1),
    _Col("n", "n", 0),
    _Col("mean", "Mean (m)"),
    _Col("std", "Std (m)"),
    _Col("rms", "RMS (m)"),
    _Col("robust_sigma", "Robust (m)"),
    _Col("skewness", "Skew", 2),
    _Col("kurtosis", "Kurt", 2),
    _Col("normal_p", "p normal", 3),
    _Col("rho1", "rho1", 3),
    _Col("corr_time_s", "tau 1/e (s)", 2),
    _Col("gm_tau_s", "tau GM (s)", 2),
    _Col("sigma_inflated", "Inflated (m)"),
)
_ALLAN_COLS = {
    "gyro": (
        _Col("platform", "Platform", -1),
        _Col("axis", "Axis", -1),
        _Col("rate_hz", "Rate (Hz)", 0),
        _Col("duration_s", "At rest (s)", 1),
        _Col("random_walk", "ARW (deg/sqrt(s))", 5),
        _Col("random_walk_per_hour", "ARW (deg/sqrt(h))", 4),
        _Col("bias_instability", "Bias inst. (deg/h)", 3),
        _Col("tau_min_s", "tau min (s)", 1),
    ),
    "accel": (
        _Col("platform", "Platform", -1),
        _Col("axis", "Axis", -1),
        _Col("rate_hz", "Rate (Hz)", 0),
        _Col("duration_s", "At rest (s)", 1),
        _Col("random_walk", "VRW ((m/s)/sqrt(s))", 6),
        _Col("random_walk_per_hour", "VRW ((m/s)/sqrt(h))", 5),
        _Col("bias_instability", "Bias inst. (mg)", 4),
        _Col("tau_min_s", "tau min (s)", 1),
    ),
}
#: Captions of the stochastic figures in report.html.
STOCHASTIC_CAPTIONS: dict[str, str] = {
    "uwb_acf": "Autocorrelation of the UWB range residuals on line-of-sight epochs per pair, "
    "with 1/e and the 95 % band of white noise (paper 002 fig. 6).",
    "uwb_pdf": "Distribution of the UWB range residuals on line-of-sight epochs per pair with "
    "the fitted Gaussian (paper 002 fig. 6).",
    "allan": "Overlapping Allan deviation of each IMU axis: white noise N / sqrt(tau) and the "
    "bias instability (minimum / 0.664).",
}


def _tables(report: StochasticReport) -> list[_Table]:
    out = []
    if report.uwb:
        out.append(
            _Table(
                "stochastic",
                "UWB range residuals on line-of-sight epochs (paper 002 sec. 5.1)",
                _UWB_COLS,
                tuple(p.stats.record() for p in report.uwb),
            )
        )
    if report.imu:
        frame = allan_frame(report.imu)
        for sensor, name in (("gyro", "Gyro"), ("accel", "Accelerometer")):
            rows = [
                {str(k): v for k, v in rec.items()}
                for rec in frame[frame["sensor"] == sensor].to_dict("records")
            ]
            out.append(
                _Table(
                    f"allan_{sensor}", f"{name} Allan deviation", _ALLAN_COLS[sensor], tuple(rows)
                )
            )
    return out


def _cell(col: _Col, value: Any, *, plain: bool = False) -> str:
    if col.decimals < 0:
        return str(value)
    v = float(value)
    if not math.isfinite(v):
        return "" if plain else "-"
    return f"{v:.{col.decimals}f}" if not plain or col.decimals == 0 else f"{v:.6g}"


def _terminal(t: _Table) -> str:
    header = [c.header for c in t.cols]
    body = [[_cell(c, r[c.key]) for c in t.cols] for r in t.rows]
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if col.decimals < 0 else c.rjust(w)
            for c, w, col in zip(cells, widths, t.cols, strict=True)
        ).rstrip()

    rule = "-" * len(line(header))
    return "\n".join([t.title, rule, line(header), rule, *map(line, body), rule]) + "\n"


def _csv(t: _Table) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([c.key for c in t.cols])
    for r in t.rows:
        writer.writerow([_cell(c, r[c.key], plain=True) for c in t.cols])
    return f"# {t.title}\n" + buf.getvalue()


def _markdown(t: _Table) -> str:
    out = [f"**{t.title}**", "", "| " + " | ".join(c.header for c in t.cols) + " |"]
    out.append("|" + "|".join("---" if c.decimals < 0 else "---:" for c in t.cols) + "|")
    out += ["| " + " | ".join(_cell(c, r[c.key]) for c in t.cols) + " |" for r in t.rows]
    return "\n".join(out) + "\n"


def _latex(t: _Table, width: LatexWidth = "single") -> str:
    """``t`` as LaTeX fitting ``width`` (:mod:`coopproc.report.latex_layout`): the header
    "Mean (m)" as "Mean" over "(m)", the leading text columns repeated if it is split."""
    tops, units = [], []
    for c in t.cols:
        found = re.match(r"^(.*?) \((.*)\)$", c.header)
        label, unit = (found.group(1), f"({found.group(2)})") if found else (c.header, "")
        tops.append(text_cell(label))
        units.append(text_cell(unit))
    if not any(u.plain for u in units):
        tops, units = [text_cell("")] * len(tops), tops
    lines = tuple(
        tuple(
            text_cell(str(r[c.key])) if c.decimals < 0 else number_cell(_cell(c, r[c.key]))
            for c in t.cols
        )
        for r in t.rows
    )
    grid = Grid(
        key=t.key.replace("_", "-"),
        title=t.title,
        caption=f"{tex_escape(t.title)}.",
        align="".join("l" if c.decimals < 0 else "r" for c in t.cols),
        tops=tuple(tops),
        units=tuple(units),
        lines=lines,
        stub=sum(1 for c in t.cols if c.decimals < 0),
    )
    return render_grid(grid, width)


def _html_table(t: _Table) -> str:
    head = "".join(f"<th>{html.escape(c.header)}</th>" for c in t.cols)
    out = [f'<table class="{t.key}"><caption>{html.escape(t.title)}</caption>']
    out.append(f"<thead><tr>{head}</tr></thead><tbody>")
    for r in t.rows:
        cells = "".join(
            f"<td>{html.escape(_cell(c, r[c.key]))}</td>"
            if c.decimals < 0
            else f'<td class="num">{html.escape(_cell(c, r[c.key]))}</td>'
            for c in t.cols
        )
        out.append(f"<tr>{cells}</tr>")
    out.append("</tbody></table>")
    return "\n".join(out) + "\n"


def uwb_toml(pairs: Sequence[PairStochastics]) -> str:
    """The ``[uwb] sigma`` to paste, from the ``all`` row (or the one pair), with comments
    on correlation and biases."""
    if not pairs:
        return ""
    row = pairs[-1].stats
    what = "all pairs, about each pair's mean" if row.pair == "all" else f"pair {row.pair}"
    lines = [
        "[uwb]",
        f"sigma = {row.std:.4f}   # m, std of the line-of-sight range residuals ({what}; "
        f"variance {row.variance_suggested:.5f} m^2, {row.n} epochs)",
    ]
    if row.correlated:
        after = f"{row.corr_time_s:.3g} s" if math.isfinite(row.corr_time_s) else "the lags shown"
        lines += [
            f"# correlated: lag-1 autocorrelation {row.rho1:.3f} at {row.interval_s:.3g} s "
            f"(below 1/e after {after}; Gauss-Markov tau {row.gm_tau_s:.3g} s):",
            f"# a white-noise filter that uses every range needs sigma = "
            f"{row.sigma_inflated:.4f} (AR(1) long-run sigma)",
        ]
    else:
        lines.append(f"# white: lag-1 autocorrelation {row.rho1:.3f} at {row.interval_s:.3g} s")
    means = [p.stats.mean for p in pairs if p.pair != "all"]
    lines.append(
        f"# range bias (mean residual) {min(means):+.3f} .. {max(means):+.3f} m over the pairs; "
        f"with the biases (RMS) {row.rms:.4f} m, for a filter that does not estimate them"
    )
    return "\n".join(lines) + "\n"


def _toml(report: StochasticReport) -> str:
    parts = [uwb_toml(report.uwb)]
    parts += [imu_toml(r) for r in report.imu]
    return "\n".join(p for p in parts if p)


def format_stochastic(
    report: StochasticReport, fmt: str, *, latex_width: LatexWidth = "single"
) -> str:
    """The tables and the session.toml snippets in ``fmt`` (terminal, csv, md, latex; the
    LaTeX fits ``latex_width``: :mod:`coopproc.report.latex_layout`)."""
    if fmt == "latex":
        text = "\n".join(_latex(t, latex_width) for t in _tables(report))
    else:
        render = {"terminal": _terminal, "csv": _csv, "md": _markdown}[fmt]
        text = "\n".join(render(t) for t in _tables(report))
    toml = _toml(report)
    if not toml:
        return text
    title = "session.toml figures from the data:"
    if fmt == "md":
        return f"{text}\n**{title}**\n\n```toml\n{toml}```\n"
    if fmt in ("csv", "latex"):
        mark = "#" if fmt == "csv" else "%"
        lines = [f"{mark} {title}", *(f"{mark} {line}" for line in toml.splitlines())]
        return text + "\n" + "\n".join(lines) + "\n"
    return f"{text}\n{title}\n\n{toml}"


def stochastic_html(report: StochasticReport, pngs: Mapping[str, bytes]) -> str:
    """The "Stochastic analysis" section of report.html: tables, snippets, figures
    (``pngs``: figure name -> PNG bytes)."""
    parts = ['<h2 id="stochastic">Stochastic analysis</h2>']
    parts += [_html_table(t) for t in _tables(report)]
    toml = _toml(report)
    if toml:
        parts.append(f"<p>session.toml figures from the data:</p><pre>{html.escape(toml)}</pre>")
    if report.notes:
        items = "".join(f"<li>{html.escape(n)}</li>" for n in report.notes)
        parts.append(f'<ul class="note">{items}</ul>')
    for name, png in pngs.items():
        data = base64.b64encode(png).decode("ascii")
        caption = html.escape(STOCHASTIC_CAPTIONS.get(name, name))
        parts.append(
            f'<figure id="fig-{name}"><img alt="{name}" src="data:image/png;base64,{data}">'
            f"<figcaption>{caption}</figcaption></figure>"
        )
    return "\n".join(parts) + "\n"
