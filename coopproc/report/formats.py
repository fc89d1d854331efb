"""Render the paper's tables as terminal text, CSV, Markdown, LaTeX (booktabs) or HTML.

Every format shows the relative change against ``observed`` in % next to each value and
marks the best value of each column within its group (pair or platform): ``*`` in the
terminal, bold in Markdown / LaTeX / HTML, the ``best`` column in CSV.
"""

from __future__ import annotations

import csv
import html
import io
from collections.abc import Sequence
from typing import Literal

from coopproc.report.injected import injected_tables
from coopproc.report.rundir import RunTables
from coopproc.report.tables import METRIC_SPECS, MetricSpec, Row, Table, build_tables, method_label

__all__ = ["Format", "format_tables", "render_table"]

Format = Literal["terminal", "csv", "md", "latex"]


def _number(name: str, value: float) -> str:
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    if value != value:  # NaN
        return "-"
    if value in (float("inf"), float("-inf")):
        return "inf" if value > 0 else "-inf"
    return f"{value:.{spec.decimals}f}"


def _change(row: Row, name: str) -> str:
    change = row.change_pct.get(name)
    return "" if change is None else f"{change:+.1f}%"


def _method(name: str) -> str:
    return method_label(name)


def _note(table: Table, best_mark: str) -> str:
    what = table.group_label.lower()
    text = f"{best_mark} best of the column within each {what}"
    if table.has_change:
        text += "; (+x.x%) relative change against Observed"
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
            header.append(f"{m}_change_pct")
    writer.writerow([*header, "best"])
    for row in table.rows:
        cells = [row.group, row.method]
        for m in table.metrics:
            value = row.values[m]
            integer = METRIC_SPECS.get(m, MetricSpec(m)).decimals == 0
            cells.append("" if value != value else (f"{value:.0f}" if integer else f"{value:.6f}"))
            if table.has_change and m != "n":
                change = row.change_pct.get(m)
                cells.append("" if change is None else f"{change:.2f}")
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


def _tex(text: str) -> str:
    for char, repl in (("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&")):
        text = text.replace(char, repl)
    return text.replace("#", r"\#")


def _tex_number(text: str) -> str:
    return f"$-${text[1:]}" if text.startswith("-") and text != "-" else text


def _latex(table: Table) -> str:
    header = [
        table.group_label,
        "Method",
        *("$n$" if m == "n" else _tex(table.header(m)) for m in table.metrics),
    ]
    caption = _tex(table.title.split(". ", 1)[-1])
    if table.has_change:
        caption += r"; in parentheses the relative change against Observed (\%)"
    caption += "; best of each column within each group in bold."
    out = [
        f"% {table.title} -- requires \\usepackage{{booktabs}}",
        r"\begin{table}[htbp]",
        r"\centering",
        f"\\caption{{{caption}}}",
        f"\\label{{tab:{table.key}}}",
        r"\begin{tabular}{ll" + "r" * len(table.metrics) + "}",
        r"\toprule",
        " & ".join(header) + r" \\",
        r"\midrule",
    ]
    previous = None
    for row in table.rows:
        if previous is not None and row.group != previous:
            out.append(r"\midrule")
        cells = [_tex(row.group) if row.group != previous else "", _tex(_method(row.method))]
        previous = row.group
        for m in table.metrics:
            text = _tex_number(_number(m, row.values[m]))
            text = f"\\textbf{{{text}}}" if m in row.best else text
            change = row.change_pct.get(m)
            if change is not None:
                text += f" ({_tex_number(f'{change:+.1f}')}\\,\\%)"
            cells.append(text)
        out.append(" & ".join(cells) + r" \\")
    out += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
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
    "latex": _latex,
    "html": _html,
}


def render_table(table: Table, fmt: Format | Literal["html"]) -> str:
    """One table in one format."""
    return _RENDERERS[fmt](table)


def format_tables(
    run: RunTables,
    fmt: Format,
    *,
    metrics: Sequence[str] | None = None,
    pairs: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
) -> str:
    """Table 2, Table 3, the NLOS scores (and, for an injected session, the injected-NLOS
    table) of a run in one format, separated by a blank line.

    See :func:`coopproc.report.tables.build_tables` for the filters. CSV output holds one
    block per table, each headed by a ``# title`` line.
    """
    if fmt not in ("terminal", "csv", "md", "latex"):
        raise ValueError(f"unknown table format {fmt!r}")
    tables = build_tables(run, metrics=metrics, pairs=pairs, platforms=platforms)
    tables += injected_tables(run, metrics=metrics, pairs=pairs)  # a run of `coopproc inject`
    return "\n".join(render_table(t, fmt) for t in tables)
