r"""The report's tables (:class:`coopproc.report.tables.Table`) as LaTeX (booktabs) that fits
the page, no ``\resizebox``.

Layout: a column per statistic (header: its short name, the unit on a second header line),
a row per method, each group (pair / platform) as an italic row of its own above its
methods instead of a first column, and the change against Observed
(:mod:`coopproc.report.change`) on a row under each method in smaller type (a dagger on
the significant ones), the confidence intervals ``lo--hi`` on a small row between them;
best values bold, minus signs ``$-$``; the caption explains only the marks shown. The
page width (``single`` / ``double``), the type size, ``table`` / ``table*`` and
splitting: :mod:`coopproc.report.latex_layout`.
"""

from __future__ import annotations

from coopproc.report.change import Change
from coopproc.report.latex_layout import (
    COLUMN_PT,
    EN_DASH,
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


def _change_cell(change: Change | None, significant: bool = False) -> Cell:
    if change is None:
        return Cell("", "", small=True)
    number = number_cell(change.number)
    unit = r"\%" if change.relative else tex_escape(change.unit)
    mark, plain_mark = (r"$^\dagger$", "\u2020") if significant else ("", "")
    if not unit:
        return Cell(f"({number.tex}{mark})", f"({number.plain}{plain_mark})", small=True)
    return Cell(
        f"({number.tex}\\,{unit}{mark})",
        f"({number.plain}{THIN}{change.unit}{plain_mark})",
        small=True,
    )


def _interval_cell(name: str, bounds: tuple[float, float] | None) -> Cell:
    """``lo--hi`` (an en dash: 12 pt narrower than ``[lo, hi]``, which split Table 3 of
    sample_logs in two at one column) in the small type of the change rows."""
    if bounds is None:
        return Cell("", "", small=True)
    lo, hi = (number_cell(number_text(name, v)) for v in bounds)
    return Cell(f"{lo.tex}--{hi.tex}", f"{lo.plain}{EN_DASH}{hi.plain}", small=True)


def _header(name: str) -> tuple[Cell, Cell]:
    if name == "n":
        return _EMPTY, Cell("$n$", "n")
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    return text_cell(_SHORT.get(name, spec.label)), text_cell(f"({spec.unit})" if spec.unit else "")


def _caption(table: Table) -> str:
    """The title, then a sentence for each mark the table shows (none for one it lacks)."""
    text = tex_escape(table.title.split(". ", 1)[-1]) + "."
    marks = table.marks
    if "interval" in marks and table.level is not None:
        text += (
            f" Under each value, its {100 * table.level:g}\\,\\% confidence interval"
            " (block bootstrap over time)."
        )
    if "change" in marks:
        text += (
            " Under each method, in smaller type, the change against Observed: in \\%"
            " for magnitudes, in the column's unit for signed values, dB and values"
            " near zero."
        )
    if "significant" in marks and table.significance is not None:
        text += (
            " $^\\dagger$: significant, a paired block-bootstrap comparison with Observed"
            f" gives $p < {table.significance:g}$."
        )
    if "best" in marks:
        text += f" Best of each column within each {table.group_label.lower()} in bold."
    return text


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
        if row.interval:
            cells = (_interval_cell(m, row.interval.get(m)) for m in table.metrics)
            lines.append((_EMPTY, *cells))
        changes = [row.change.get(m) for m in table.metrics]
        if any(c is not None for c in changes):
            marked = (
                _change_cell(c, m in row.significant)
                for c, m in zip(changes, table.metrics, strict=True)
            )
            lines.append((_EMPTY, *marked))
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
