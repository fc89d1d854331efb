"""Render the paper's tables as terminal text, CSV, Markdown, LaTeX (booktabs) or HTML.

Every format shows the confidence interval of each statistic that has one after its value
(``0.0389 [0.0351, 0.0427]``: :mod:`coopproc.report.table_stats`), the change against
``observed`` next to each value (in % for magnitudes,
in the column's unit for signed statistics, dB and near-zero references:
:mod:`coopproc.report.change`; ``change=False`` leaves it out) and marks the best value of
each column within its group (pair or platform): ``*`` in the terminal, bold in Markdown /
LaTeX / HTML, the ``best`` column in CSV; a change whose paired comparison is significant
gets a dagger (the ``significant`` column in CSV). The note under a table explains only the
marks it shows. The LaTeX form is :mod:`coopproc.report.latex`.
"""

from __future__ import annotations

import csv
import dataclasses
import html
import io
from collections.abc import Sequence
from typing import Literal

from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.injected import injected_tables
from coopproc.report.latex import LatexWidth, latex_table
from coopproc.report.run_tables import RunTables
from coopproc.report.table_stats import DEFAULT_SIGNIFICANCE
from coopproc.report.tables import (
    METRIC_SPECS,
    MetricSpec,
    Row,
    Table,
    build_tables,
    method_label,
    number_text,
)

__all__ = [
    "CHANGE_NOTE",
    "SIGNIFICANT_MARK",
    "Format",
    "format_tables",
    "interval_note",
    "render_table",
    "significance_note",
    "table_note",
    "without_change",
]

#: What the change after a value means (the notes under the tables).
CHANGE_NOTE = (
    "change against Observed: in % for magnitudes, in the column's unit for signed values, "
    "dB and values near zero"
)

Format = Literal["terminal", "csv", "md", "latex"]


def _number(name: str, value: float) -> str:
    return number_text(name, value)


#: The mark of a significant change (after the change, inside its parentheses).
SIGNIFICANT_MARK = "\u2020"


def _change(row: Row, name: str) -> str:
    change = row.change.get(name)
    if change is None:
        return ""
    return change.text() + (SIGNIFICANT_MARK if name in row.significant else "")


def _interval(row: Row, name: str) -> str:
    """`` [lo, hi]`` of a statistic with an interval, else empty."""
    bounds = row.interval.get(name)
    if bounds is None:
        return ""
    return f" [{_number(name, bounds[0])}, {_number(name, bounds[1])}]"


def _method(name: str) -> str:
    return method_label(name)


def interval_note(level: float) -> str:
    """What the brackets after a value are."""
    return (
        f"in brackets the {100 * level:g} % confidence interval (block bootstrap over time; "
        "docs/report.md)"
    )


def significance_note(alpha: float) -> str:
    """What the mark after a change is."""
    return (
        f"{SIGNIFICANT_MARK} the change is significant: a paired block-bootstrap comparison "
        f"with Observed gives p < {alpha:g}"
    )


def table_note(table: Table, best_mark: str) -> str:
    """The note under a table: what each of its marks means, only for the marks it shows
    (empty when it shows none)."""
    marks = table.marks
    parts = []
    if "best" in marks:
        parts.append(f"{best_mark} best of the column within each {table.group_label.lower()}")
    if "interval" in marks and table.level is not None:
        parts.append(interval_note(table.level))
    if "change" in marks:
        parts.append(f"in parentheses the {CHANGE_NOTE}")
    if "significant" in marks and table.significance is not None:
        parts.append(significance_note(table.significance))
    return "; ".join(parts)


def _terminal(table: Table) -> str:
    header = [table.group_label, "Method", *(table.header(m) for m in table.metrics)]
    body: list[list[str]] = []
    previous = None
    for row in table.rows:
        cells = [row.group if row.group != previous else "", _method(row.method)]
        previous = row.group
        for m in table.metrics:
            text = _number(m, row.values[m]) + _interval(row, m)
            change = _change(row, m)
            text += f" ({change})" if change else ""
            cells.append(text + ("*" if m in row.best else " "))
        body.append(cells)
    widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        left = [c.ljust(w) for c, w in zip(cells[:2], widths[:2], strict=True)]
        right = [c.rjust(w) for c, w in zip(cells[2:], widths[2:], strict=True)]
        return "  ".join(left + right).rstrip()

    rule = "-" * len(line(header))
    out = [table.title, rule, line(header), rule]
    out += [line(r) for r in body]
    out += [rule]
    note = table_note(table, "*")
    out += [note] if note else []
    return "\n".join(out) + "\n"


def _csv(table: Table) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    header = [table.group_label.lower(), "method"]
    for m in table.metrics:
        header.append(m)
        if table.has_change and m != "n":
            header += [f"{m}_change", f"{m}_change_unit"]
    bounded = [m for m in table.metrics if any(m in r.interval for r in table.rows)]
    extra = [f"{m}_{end}" for m in bounded for end in ("lo", "hi")]
    extra += ["significant"] if table.significance is not None else []
    writer.writerow([*header, "best", *extra])
    for row in table.rows:
        cells = [row.group, row.method]
        for m in table.metrics:
            value = row.values[m]
            integer = METRIC_SPECS.get(m, MetricSpec(m)).decimals == 0
            cells.append("" if value != value else (f"{value:.0f}" if integer else f"{value:.6f}"))
            if table.has_change and m != "n":
                change = row.change.get(m)
                if change is None:
                    cells += ["", ""]
                elif change.relative:
                    cells += [f"{change.value:.2f}", change.unit]
                else:
                    cells += [f"{change.value:.6f}", change.unit]
        cells.append(";".join(m for m in table.metrics if m in row.best))
        for m in bounded:
            lo, hi = row.interval.get(m, (float("nan"), float("nan")))
            cells += ["" if v != v else f"{v:.6f}" for v in (lo, hi)]
        if table.significance is not None:
            cells.append(";".join(m for m in table.metrics if m in row.significant))
        writer.writerow(cells)
    return f"# {table.title}\n" + buf.getvalue()


def _markdown(table: Table) -> str:
    header = [table.group_label, "Method", *(table.header(m) for m in table.metrics)]
    out = [f"**{table.title}**", "", "| " + " | ".join(header) + " |"]
    out.append("|" + "|".join(["---", "---"] + ["---:"] * len(table.metrics)) + "|")
    previous = None
    for row in table.rows:
        cells = [row.group if row.group != previous else "", _method(row.method)]
        previous = row.group
        for m in table.metrics:
            text = _number(m, row.values[m])
            text = (f"**{text}**" if m in row.best else text) + _interval(row, m)
            change = _change(row, m)
            cells.append(f"{text} ({change})" if change else text)
        out.append("| " + " | ".join(cells) + " |")
    note = table_note(table, "Bold:")
    out += ["", f"*{note}*"] if note else []
    return "\n".join(out) + "\n"


def _html(table: Table) -> str:
    head = "".join(
        f"<th>{html.escape(h)}</th>"
        for h in [table.group_label, "Method", *(table.header(m) for m in table.metrics)]
    )
    out = [f'<table class="{table.key}">', f"<caption>{html.escape(table.title)}</caption>"]
    out.append(f"<thead><tr>{head}</tr></thead><tbody>")
    previous = None
    for row in table.rows:
        cells = [
            f"<td>{html.escape(row.group) if row.group != previous else ''}</td>",
            f"<td>{html.escape(_method(row.method))}</td>",
        ]
        previous = row.group
        for m in table.metrics:
            text = html.escape(_number(m, row.values[m]))
            text = f"<b>{text}</b>" if m in row.best else text
            text += html.escape(_interval(row, m))
            change = _change(row, m)
            text += f' <span class="chg">({change})</span>' if change else ""
            cells.append(f'<td class="num">{text}</td>')
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    note = table_note(table, "Bold:")
    if note:
        out.append(f'<p class="note">{html.escape(note)}</p>')
    return "\n".join(out) + "\n"


_RENDERERS = {
    "terminal": _terminal,
    "csv": _csv,
    "md": _markdown,
    "html": _html,
}


def without_change(table: Table) -> Table:
    """``table`` without the changes against Observed (``--no-change``)."""
    rows = tuple(
        dataclasses.replace(r, change={m: None for m in r.change}, significant=frozenset())
        for r in table.rows
    )
    return dataclasses.replace(table, rows=rows, has_change=False, significance=None)


def render_table(
    table: Table,
    fmt: Format | Literal["html"],
    *,
    change: bool = True,
    latex_width: LatexWidth = "single",
) -> str:
    """One table in one format; ``change=False``: without the changes against Observed;
    ``latex_width``: the page layout the LaTeX form fits (:mod:`coopproc.report.latex`)."""
    if not change:
        table = without_change(table)
    if fmt == "latex":
        return latex_table(table, latex_width)
    return _RENDERERS[fmt](table)


def format_tables(
    run: RunTables,
    fmt: Format,
    *,
    metrics: Sequence[str] | None = None,
    pairs: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    change: bool = True,
    latex_width: LatexWidth = "single",
    axes: bool = False,
    level: float | None = DEFAULT_LEVEL,
    significance: float | None = DEFAULT_SIGNIFICANCE,
) -> str:
    """Table 2, Table 3 (``axes``: and Table 3 per axis), the NLOS scores (and, for an
    injected session, the injected-NLOS table) of a run in one format, separated by a
    blank line.

    See :func:`coopproc.report.tables.build_tables` for the filters, ``level`` (the
    intervals) and ``significance`` (the marks), :func:`render_table` for ``change`` and
    ``latex_width``. CSV output holds one block per
    table, each headed by a ``# title`` line.
    """
    if fmt not in ("terminal", "csv", "md", "latex"):
        raise ValueError(f"unknown table format {fmt!r}")
    tables = build_tables(
        run,
        metrics=metrics,
        pairs=pairs,
        platforms=platforms,
        axes=axes,
        level=level,
        significance=significance if change else None,
    )
    tables += injected_tables(run, metrics=metrics, pairs=pairs)  # a run of `coopproc inject`
    return "\n".join(render_table(t, fmt, change=change, latex_width=latex_width) for t in tables)
