"""``OUT/report.html``: one page with the tables, the figures and the run facts.

Figures are embedded as base64 PNG: the ``OUT/figures/<name>.png`` files where they exist,
else rendered in memory from the tables. While the figures are small the page has no
external resources, so it opens in any browser and can be mailed as one file; when their
files are large (many pairs, long runs) it shows a reduced first page of each and links
the PNG files in ``figures/`` (:mod:`coopproc.report.html_figures`).
"""

from __future__ import annotations

import html
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.evaluation_tables import evaluation_html
from coopproc.report.figures import FigurePage
from coopproc.report.formats import render_table
from coopproc.report.html_figures import figures_section
from coopproc.report.injected import injected_tables
from coopproc.report.pages import FigureOptions
from coopproc.report.run_tables import RunTables
from coopproc.report.scores import NLOS_EVENT_SCORE_COLUMNS, nlos_event_scores
from coopproc.report.stochastic import StochasticReport
from coopproc.report.stochastic_figures import stochastic_section
from coopproc.report.table_stats import DEFAULT_SIGNIFICANCE, table_frames
from coopproc.report.tables import (
    POSITION_ALL,
    distance_table,
    fusion_outlier_table,
    method_label,
    nlos_table,
    position_table,
    run_method_orders,
)

__all__ = ["FIGURE_CAPTIONS", "render_html", "write_html"]

FIGURE_CAPTIONS: dict[str, str] = {
    "distance_errors": "Distance error per pair and method; detected NLOS spans shaded "
    "(paper 000 fig. 9 and 11).",
    "di_errors": "Distance-increment error of dead reckoning, cooperative positioning and "
    "the smoothed DI against the reference DI (paper 000 fig. 8).",
    "position_errors": "Horizontal position error per platform and method (paper 000 fig. 12).",
    "nlos_convergence": "NLOS estimate after each step of eq. (11) per event (paper 000 fig. "
    "10): a panel per event of the primary method, other methods' events in the panel they "
    "overlap, else in a panel of their own named by their method.",
    "trajectories": "Tracks in the east-north plane with the reference.",
    "error_cdf": "Cumulative distribution of the horizontal error per platform, methods "
    "overlaid (dotted: 50 % and 95 %, i.e. CEP50 and CEP95).",
    "outage_drift": "Horizontal error against time since each UWB outage started (the ranges "
    "withheld there: coopproc run --outage), one line per outage window, per method "
    "(paper 003 fig. 9-10).",
    "error_track": "Track of the primary method coloured by its horizontal error (scale 0 to "
    "the 95th percentile), over the reference (thin black).",
}

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.85em; }
caption { text-align: left; font-weight: bold; padding-bottom: 0.4em; }
th, td { padding: 0.2em 0.6em; border-bottom: 1px solid #e5e5e5; white-space: nowrap; }
div.wide { overflow-x: auto; } ul.notes { margin: 0; padding-left: 1.2em; }
thead th { border-bottom: 2px solid #444; text-align: right; }
thead th:first-child, thead th:nth-child(2) { text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.chg { color: #777; font-size: 0.9em; } .note { color: #555; font-size: 0.8em; }
figure { margin: 1.5em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { color: #444; font-size: 0.9em; } dt { font-weight: bold; }
figure a img { display: block; margin-bottom: 0.3em; }
"""


#: Display names of the columns of the NLOS events table (nlos_event_scores.csv).
EVENT_HEADERS: dict[str, str] = {
    "pair": "Pair",
    "method": "Method",
    "start": "Start (s)",
    "end": "End (s)",
    "epochs": "Epochs",
    "estimate": "Estimate (m)",
    "reference_bias": "Reference bias (m)",
    "error": "Error (m)",
}


def _number(value: Any, digits: int) -> str:
    """A float at ``digits`` decimals, anything else as it is."""
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def _facts(info: Mapping[str, Any]) -> str:
    items: list[tuple[str, str]] = []
    session = info.get("session")
    if isinstance(session, Mapping):
        items.append(("Session", f"{session.get('name', '')} ({session.get('path', '')})"))
    for key, label in (
        ("coopproc_version", "coopproc"),
        ("version", "coopproc"),
        ("python", "Python"),
        ("start_time", "Started"),
        ("duration_s", "Duration (s)"),
    ):
        if key in info:
            items.append((label, str(info[key])))
    sigma = info.get("sigma")
    if isinstance(sigma, Mapping) and sigma:
        parts = []
        for pair, value in sorted(sigma.items()):
            if isinstance(value, Mapping):
                sigma_m = _number(value.get("sigma_m"), 4)
                parts.append(f"{pair}: {sigma_m} m ({value.get('source', '')})")
            else:
                parts.append(f"{pair}: {_number(value, 4)} m")
        items.append(("UWB sigma", "; ".join(parts)))
    timings = info.get("timings_s")
    if isinstance(timings, Mapping) and timings:
        items.append(
            ("Stage times (s)", "; ".join(f"{k}: {_number(v, 2)}" for k, v in timings.items()))
        )
    out = ["<dl>"]
    out += [f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in items]
    notes = info.get("notes")
    if isinstance(notes, list) and notes:  # one item a note: they are sentences of their own
        listed = "".join(f"<li>{html.escape(str(n))}</li>" for n in notes)
        out.append(f'<dt>Notes</dt><dd><ul class="notes">{listed}</ul></dd>')
    out.append("</dl>")
    inputs = info.get("inputs")
    if isinstance(inputs, list) and inputs:
        out.append('<table class="inputs"><caption>Inputs</caption>')
        out.append("<thead><tr><th>File</th><th>SHA-256</th></tr></thead><tbody>")
        for item in inputs:
            if isinstance(item, Mapping):
                out.append(
                    f"<tr><td>{html.escape(str(item.get('file', '')))}</td>"
                    f"<td><code>{html.escape(str(item.get('sha256', '')))}</code></td></tr>"
                )
        out.append("</tbody></table>")
    if "config" in info:
        config = json.dumps(info["config"], indent=2, sort_keys=True, default=str)
        out.append(
            "<details><summary>Effective configuration</summary>"
            f"<pre>{html.escape(config)}</pre></details>"
        )
    return "\n".join(out)


def _event_table(run: RunTables) -> str:
    frame = run.nlos_event_scores
    if frame is None and {"observed", "reference"} <= set(run.ranges.columns):
        frame = nlos_event_scores(run.ranges, run.nlos_events)  # derived, no processing
    if frame is None or not len(frame):
        return ""
    cols = list(NLOS_EVENT_SCORE_COLUMNS)
    t0 = run.time_origin_s
    out = ['<table class="nlos_events"><caption>NLOS events against the reference</caption>']
    head = "".join(f"<th>{html.escape(EVENT_HEADERS[c])}</th>" for c in cols)
    out.append(f"<thead><tr>{head}</tr></thead><tbody>")
    for rec in frame[cols].to_dict("records"):
        cells = [
            f"<td>{html.escape(str(rec['pair']))}</td>",
            f"<td>{html.escape(method_label(str(rec['method'])))}</td>",
        ]
        for c in cols[2:]:
            v = rec[c]
            if c in ("start", "end"):
                v = float(v) - t0
                text = f"{v:.1f}"
            else:
                text = html.escape(_number(v, 4))
            cells.append(f'<td class="num">{text}</td>')
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    out.append(
        f'<p class="note">Start and end in s since t0 = {t0:.3f} s (as in the figures); '
        "reference bias: mean of observed - reference over the event; error: estimate - "
        "reference bias.</p>"
    )
    return "\n".join(out)


def _wide(block: str) -> str:
    """A table (and its note) that scrolls sideways on a narrow page instead of wrapping."""
    return f'<div class="wide">{block}</div>' if block else ""


#: The Figures section of a page written without figures (``coopproc run --no-figures``).
NO_FIGURES = (
    '<h2>Figures</h2>\n<p class="note">No figures: the run was made without them '
    "(<code>coopproc run --no-figures</code>, or <code>[run] figures = false</code>). "
    "<code>coopproc report OUT --plots --html</code> draws them and writes this page again "
    "with them.</p>"
)


def render_html(
    out_dir: Path,
    run: RunTables,
    stochastic: StochasticReport | None = None,
    options: FigureOptions | None = None,
    *,
    figures: bool = True,
    pages: Sequence[FigurePage] | None = None,
) -> str:
    """The page as a string (see :func:`write_html`)."""
    session = run.info.get("session")
    name = session.get("name", "") if isinstance(session, Mapping) else ""
    title = f"coopproc report {name}".strip()
    order = run_method_orders(run)
    # intervals and significance marks as `report --table` shows them (report/table_stats.py)
    frames = table_frames(run, DEFAULT_LEVEL, DEFAULT_SIGNIFICANCE, order)
    table2 = distance_table(
        frames.metrics, order=order["table2"], level=DEFAULT_LEVEL, stars=frames.distance_stars
    )
    table3 = position_table(
        frames.position_metrics,
        POSITION_ALL,
        order=order["table3"],
        level=DEFAULT_LEVEL,
        stars=frames.position_stars,
    )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        "<h2>Run</h2>",
        _facts(run.info),
        "<h2>Tables</h2>",
        _wide(render_table(table2, "html")),
        _wide(render_table(table3, "html")),
    ]
    if run.nlos_scores is not None and len(run.nlos_scores):
        parts.append(_wide(render_table(nlos_table(run.nlos_scores, order=order["nlos"]), "html")))
        outliers = fusion_outlier_table(run.nlos_scores)
        if outliers.rows:
            parts.append(_wide(render_table(outliers, "html")))
    parts.append(_wide(_event_table(run)))
    # a run of a `coopproc inject` session: the injected NLOS against each method's estimate
    parts.extend(_wide(render_table(t, "html")) for t in injected_tables(run))
    # 3-D / vertical errors and RPE (evaluation.csv, rpe.csv)
    parts.append(_wide(evaluation_html(run)))
    if figures:
        parts.append(figures_section(Path(out_dir), run, options, FIGURE_CAPTIONS, pages))
    else:
        parts.append(NO_FIGURES)
    if stochastic is not None:  # coopproc report OUT --stochastic --html
        parts.append(stochastic_section(stochastic))
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p) + "\n"


def write_html(
    out_dir: Path,
    run: RunTables,
    stochastic: StochasticReport | None = None,
    options: FigureOptions | None = None,
    *,
    figures: bool = True,
    pages: Sequence[FigurePage] | None = None,
) -> Path:
    """Write ``out_dir/report.html`` and return its path; ``stochastic`` adds the
    stochastic-analysis section (:mod:`coopproc.report.stochastic`); ``options``: the
    pairs, platforms and panels per page of the figures (as given to ``write_figures``);
    ``figures=False``: no figures, the section says so (``coopproc run --no-figures``);
    ``pages``: the pages of ``figure_pages(run, options)`` if the caller listed them
    (``write_run``: not built twice)."""
    path = Path(out_dir) / "report.html"
    page = render_html(Path(out_dir), run, stochastic, options, figures=figures, pages=pages)
    path.write_text(page, encoding="utf-8")
    return path
