r"""The report's tables (:class:`coopproc.report.tables.Table`) as LaTeX (booktabs) that fits
the page, no ``\resizebox``.

Layout: a column per statistic (header: its short name, the unit on a second header line),
a row per method, each group (pair / platform) as an italic row of its own above its
methods instead of a first column, and the change against Observed
(:mod:`coopproc.report.change`) on a second row under each method in smaller type; best
values bold, minus signs ``$-$``. The page width (``single`` / ``double``), the type size,
``table`` / ``table*`` and splitting: :mod:`coopproc.report.latex_layout`.
"""

from __future__ import annotations

from coopproc.report.change import Change
from coopproc.report.latex_layout import (
    COLUMN_PT,
    SINGLE_PT,
    SPAN_PT,
    THIN,
    Cell,
    Grid,
    LatexWidth,
    Line,
    number_cell,
    render_grid,
    tex_escape,
    text_cell,
)
from coopproc.report.tables import METRIC_SPECS, MetricSpec, Table, method_label, number_text

__all__ = ["COLUMN_PT", "SINGLE_PT", "SPAN_PT", "LatexWidth", "latex_table", "tex_escape"]

#: Shorter headers than the other formats' (:data:`coopproc.report.tables.METRIC_SPECS`).
_SHORT = {"smoothness": "Smooth.", "precision": "Prec.", "estimate_mae": "Est. MAE"}
_EMPTY = Cell("", "")


def _change_cell(change: Change | None) -> Cell:
    if change is None:
        return Cell("", "", small=True)
    number = number_cell(change.number)
    unit = r"\%" if change.relative else tex_escape(change.unit)
    if not unit:
        return Cell(f"({number.tex})", f"({number.plain})", small=True)
    return Cell(f"({number.tex}\\,{unit})", f"({number.plain}{THIN}{change.unit})", small=True)


def _header(name: str) -> tuple[Cell, Cell]:
    if name == "n":
        return _EMPTY, Cell("$n$", "n")
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    return text_cell(_SHORT.get(name, spec.label)), text_cell(f"({spec.unit})" if spec.unit else "")


def _caption(table: Table) -> str:
    text = tex_escape(table.title.split(". ", 1)[-1]) + "."
    if table.has_change:
        text += (
            " Under each method, in smaller type, the change against Observed: in \\%"
            " for magnitudes, in the column's unit for signed values, dB and values"
            " near zero."
        )
    return f"{text} Best of each column within each {table.group_label.lower()} in bold."


def table_grid(table: Table) -> Grid:
    """``table`` as the cells of the layout (see the module)."""
    tops, units = zip(*(_header(m) for m in table.metrics), strict=True)
    lines: list[Line] = []
    previous = None
    for row in table.rows:
        if row.group != previous:
            lines.append(f"{table.group_label} {row.group}")
            previous = row.group
        values = (number_cell(number_text(m, row.values[m]), m in row.best) for m in table.metrics)
        lines.append((text_cell(method_label(row.method)), *values))
        changes = [row.change.get(m) for m in table.metrics]
        if any(c is not None for c in changes):
            lines.append((_EMPTY, *(_change_cell(c) for c in changes)))
    return Grid(
        key=table.key,
        title=table.title,
        caption=_caption(table),
        align="l" + "r" * len(table.metrics),
        tops=(_EMPTY, *tops),
        units=(Cell("Method", "Method"), *units),
        lines=tuple(lines),
    )


def latex_table(table: Table, width: LatexWidth = "single") -> str:
    """``table`` as LaTeX fitting ``width`` (:func:`coopproc.report.latex_layout.render_grid`)."""
    return render_grid(table_grid(table), width)
