"""Render the paper's tables as terminal text, CSV, Markdown, LaTeX (booktabs) or HTML.

Every format shows the change against ``observed`` next to each value (in % for magnitudes,
in the column's unit for signed statistics, dB and near-zero references:
:mod:`coopproc.report.change`; ``change=False`` leaves it out) and marks the best value of
each column within its group (pair or platform): ``*`` in the terminal, bold in Markdown /
LaTeX / HTML, the ``best`` column in CSV. The LaTeX form is :mod:`coopproc.report.latex`.
"""

from __future__ import annotations

import csv
import dataclasses
import html
import io
from collections.abc import Sequence
from typing import Literal

from coopproc.report.injected import injected_tables
from coopproc.report.latex import LatexWidth, latex_table
from coopproc.report.rundir import RunTables
from coopproc.report.tables import (
    METRIC_SPECS,
    MetricSpec,
    Row,
    Table,
    build_tables,
    method_label,
    number_text,
)

__all__ = ["CHANGE_NOTE", "Format", "format_tables", "render_table", "without_change"]

#: What the change after a value means (the notes under the tables).
CHANGE_NOTE = (
    "change against Observed: in % for magnitudes, in the column's unit for signed values, "
    "dB and values near zero"
)

Format = Literal["terminal", "csv", "md", "latex"]


def _number(name: str, value: float) -> str:
    return number_text(name, value)


def _change(row: Row, name: str) -> str:
    change = row.change.get(name)
    return "" if change is None else change.text()


def _method(name: str) -> str:
    return method_label(name)


def _note(table: Table, best_mark: str) -> str:
    what = table.group_label.lower()
    text = f"{best_mark} best of the column within each {what}"
    if table.has_change:
        text += f"; in parentheses the {CHANGE_NOTE}"
    return text


def _terminal(table: Table) -> str:
    header = [table.group_label, "Method", *(table.header(m) for m in table.metrics)]
    body: list[list[str]] = []
    previous = None
    for row in table.rows:
        cells = [row.group if row.group != previous else "", _method(row.method)]
        previous = row.group
        for m in table.metrics:
            text = _number(m, row.values[m])
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
    out += [rule, _note(table, "*")]
    return "\n".join(out) + "\n"


def _csv(table: Table) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    header = [table.group_label.lower(), "method"]
    for m in table.metrics:
        header.append(m)
        if table.has_change and m != "n":
            header += [f"{m}_change", f"{m}_change_unit"]
    writer.writerow([*header, "best"])
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
            text = f"**{text}**" if m in row.best else text
            change = _change(row, m)
            cells.append(f"{text} ({change})" if change else text)
        out.append("| " + " | ".join(cells) + " |")
    out += ["", f"*{_note(table, 'Bold:')}*"]
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
            change = _change(row, m)
            text += f' <span class="chg">({change})</span>' if change else ""
            cells.append(f'<td class="num">{text}</td>')
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    out.append(f'<p class="note">{html.escape(_note(table, "Bold:"))}</p>')
    return "\n".join(out) + "\n"


_RENDERERS = {
    "terminal": _terminal,
    "csv": _csv,
    "md": _markdown,
    "html": _html,
}


def without_change(table: Table) -> Table:
    """``table`` without the changes against Observed (``--no-change``)."""
    rows = tuple(dataclasses.replace(r, change={m: None for m in r.change}) for r in table.rows)
    return dataclasses.replace(table, rows=rows, has_change=False)


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
) -> str:
    """Table 2, Table 3 (``axes``: and Table 3 per axis), the NLOS scores (and, for an
    injected session, the injected-NLOS table) of a run in one format, separated by a
    blank line.

    See :func:`coopproc.report.tables.build_tables` for the filters and
    :func:`render_table` for ``change`` and ``latex_width``. CSV output holds one block per
    table, each headed by a ``# title`` line.
    """
    if fmt not in ("terminal", "csv", "md", "latex"):
        raise ValueError(f"unknown table format {fmt!r}")
    tables = build_tables(run, metrics=metrics, pairs=pairs, platforms=platforms, axes=axes)
    tables += injected_tables(run, metrics=metrics, pairs=pairs)  # a run of `coopproc inject`
    return "\n".join(render_table(t, fmt, change=change, latex_width=latex_width) for t in tables)
