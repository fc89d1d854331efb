r"""The report's tables as LaTeX (booktabs), laid out to fit a journal page, no ``\resizebox``.

Layout of every table: a column per statistic (header: its short name, the unit on a
second header line), a row per method, each group (pair / platform) as a row of its own
above its methods instead of a first column, and the change against Observed
(:mod:`coopproc.report.change`) on a second row under each method in smaller type; best
values bold, minus signs ``$-$``.

``width``: ``single`` fits a one-column article (a ``table`` at most :data:`SINGLE_PT` wide:
article's 10 pt default text width; 2 cm margins give 483 pt and more room); ``double``
fits one column of a two-column article (a ``table`` at most :data:`COLUMN_PT`: A4, the
narrowest usual column; IEEE's is 252 pt) and else spans both columns as ``table*`` (at
most :data:`SPAN_PT`). Within its target the table takes the largest type that fits:
normal size, ``\small`` or ``\footnotesize`` (with ``\tabcolsep`` 6, 4, 3 pt), its width
estimated from Computer Modern's character widths; a table too wide even so is split into
tables of consecutive columns ("continued"). The comment above each table names the
packages it needs (booktabs only) and the layout taken.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

from coopproc.report.change import Change
from coopproc.report.tables import METRIC_SPECS, MetricSpec, Table, method_label, number_text

__all__ = ["COLUMN_PT", "SINGLE_PT", "SPAN_PT", "LatexWidth", "latex_table", "tex_escape"]

LatexWidth = Literal["single", "double"]

#: \linewidth targets, pt: one-column article; one column / both columns of a two-column
#: A4 article (article class, 10 pt).
SINGLE_PT = 345.0
COLUMN_PT = 221.0
SPAN_PT = 452.0

#: Shorter headers than the other formats' (:data:`coopproc.report.tables.METRIC_SPECS`).
_SHORT = {"smoothness": "Smooth.", "precision": "Prec.", "estimate_mae": "Est. MAE"}

# Widths of the printable ASCII characters (32..126) in cmr10 / cmbx10, 1/100 pt.
_ROMAN = (
    "333 278 500 833 500 833 778 278 389 389 500 778 278 333 278 500 500 500 500 500 500 500 "
    "500 500 500 500 278 278 778 778 778 472 778 750 708 722 764 681 653 785 750 361 514 778 "
    "625 917 750 778 681 778 736 556 722 750 750 1028 750 750 611 278 500 278 500 360 278 500 "
    "556 444 556 444 306 500 556 278 306 528 278 833 556 500 556 528 392 394 389 556 528 722 "
    "528 528 444 500 278 500 500"
)
_BOLD = (
    "383 350 603 958 575 958 894 319 447 447 575 894 319 383 319 575 575 575 575 575 575 575 "
    "575 575 575 575 319 319 894 894 894 543 894 869 818 831 882 756 724 904 900 436 594 901 "
    "692 1092 900 864 786 864 862 639 800 885 869 1189 869 869 703 319 575 319 575 414 319 559 "
    "639 511 639 527 351 575 639 319 351 607 319 958 639 575 639 607 474 454 447 639 607 831 "
    "607 607 511 575 319 575 575"
)
_WIDTHS = {
    False: [int(w) / 100 for w in _ROMAN.split()],
    True: [int(w) / 100 for w in _BOLD.split()],
}
_MINUS = "\u2212"  # math minus, 7.78 pt
_THIN = "\u2009"  # \, 1.67 pt


def _text_width(text: str, bold: bool) -> float:
    """Width of ``text`` at 10 pt, pt (other characters: 10 pt, on the safe side)."""
    widths = _WIDTHS[bold]
    total = 0.0
    for char in text:
        code = ord(char)
        if 32 <= code < 127:
            total += widths[code - 32]
        else:
            total += {_MINUS: 7.78, _THIN: 1.67}.get(char, 10.0)
    return total


@dataclass(frozen=True)
class _Size:
    """A type size of the table: its command, scale against 10 pt, \\tabcolsep; the type of
    the change rows."""

    command: str
    scale: float
    tabcolsep: float
    change_command: str
    change_scale: float


_SIZES = (
    _Size("", 1.0, 6.0, r"\footnotesize", 0.85),
    _Size(r"\small", 0.925, 4.0, r"\scriptsize", 0.793),
    _Size(r"\footnotesize", 0.85, 3.0, r"\scriptsize", 0.793),
)


@dataclass(frozen=True)
class _Cell:
    """One cell: its LaTeX and the text whose width it takes (``plain``)."""

    tex: str
    plain: str
    bold: bool = False
    change: bool = False  # in the smaller type of the change rows

    def width(self, size: _Size) -> float:
        scale = size.change_scale if self.change else size.scale
        return _text_width(self.plain, self.bold) * scale


def tex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped."""
    out = text.replace("\\", r"\textbackslash{}")
    for char in "_%&#$":
        out = out.replace(char, "\\" + char)
    for char, repl in (("{", r"\{"), ("}", r"\}"), ("^", r"\^{}"), ("~", r"\~{}")):
        out = out.replace(char, repl)
    return out.replace(r"\textbackslash\{\}", r"\textbackslash{}")


def _number(text: str, bold: bool = False) -> _Cell:
    if text == "-":  # undefined (NaN): an en dash
        return _Cell("--", "--")
    tex = f"$-${text[1:]}" if text.startswith("-") and text != "-" else text
    plain = _MINUS + text[1:] if tex != text else text
    return _Cell(f"\\textbf{{{tex}}}" if bold else tex, plain, bold)


def _change_cell(change: Change | None, size: _Size) -> _Cell:
    if change is None:
        return _Cell("", "", change=True)
    number = _number(change.number)
    unit = r"\%" if change.relative else tex_escape(change.unit)
    tex = f"({number.tex}\\,{unit})" if unit else f"({number.tex})"
    plain = f"({number.plain}{_THIN}{change.unit})" if unit else f"({number.plain})"
    return _Cell(f"{{{size.change_command} {tex}}}", plain, change=True)


def _header(name: str) -> tuple[_Cell, _Cell]:
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    if name == "n":
        return _Cell("", ""), _Cell("$n$", "n")
    label = _SHORT.get(name, spec.label)
    unit = f"({spec.unit})" if spec.unit else ""
    return _Cell(tex_escape(label), label), _Cell(tex_escape(unit), unit)


def _rows(table: Table, size: _Size) -> list[list[_Cell] | str]:
    """Header and body: lists of cells, or a string for a full-width line (group row)."""
    tops, units = zip(*(_header(m) for m in table.metrics), strict=True)
    out: list[list[_Cell] | str] = []
    if any(c.plain for c in tops):
        out.append([_Cell("", ""), *tops])
    out.append([_Cell("Method", "Method"), *units])
    previous = None
    for row in table.rows:
        if row.group != previous:
            out.append(f"{table.group_label} {row.group}")
            previous = row.group
        label = method_label(row.method)
        cells = [_Cell(tex_escape(label), label)]
        cells += [_number(number_text(m, row.values[m]), m in row.best) for m in table.metrics]
        out.append(cells)
        changes = [row.change.get(m) for m in table.metrics]
        if any(c is not None for c in changes):
            out.append([_Cell("", ""), *(_change_cell(c, size) for c in changes)])
    return out


def _width(table: Table, size: _Size) -> float:
    """Estimated width of the tabular, pt (columns ``@{}`` at both ends)."""
    rows = _rows(table, size)
    cols = [0.0] * (len(table.metrics) + 1)
    group = 0.0
    for line in rows:
        if isinstance(line, str):
            group = max(group, _text_width(line, False) * size.scale)
            continue
        for i, cell in enumerate(line):
            cols[i] = max(cols[i], cell.width(size))
    total = sum(cols) + 2 * size.tabcolsep * (len(cols) - 1)
    return max(total, group) * 1.02 + 1.0  # a margin for the estimate


def _fit(table: Table, target: float) -> _Size | None:
    return next((s for s in _SIZES if _width(table, s) <= target), None)


def _caption(table: Table, part: int) -> str:
    what = table.group_label.lower()
    text = tex_escape(table.title.split(". ", 1)[-1])
    if part:
        return f"{text} (continued)."
    text += "."
    if table.has_change:
        text += (
            " Under each method, in smaller type, the change against Observed: in \\%"
            " for magnitudes, in the column's unit for signed values, dB and values"
            " near zero."
        )
    return f"{text} Best of each column within each {what} in bold."


def _render(table: Table, size: _Size, env: str, layout: str, part: int = 0) -> str:
    ncols = len(table.metrics) + 1
    label = table.key if not part else f"{table.key}-{part + 1}"
    out = [
        f"% {table.title}{' (continued)' if part else ''}",
        f"% needs \\usepackage{{booktabs}}; {layout}, about {_width(table, size):.0f} pt wide",
        f"\\begin{{{env}}}[htbp]",
        r"\centering",
        f"\\caption{{{_caption(table, part)}}}",
        f"\\label{{tab:{label}}}",
    ]
    if size.command:
        out.append(size.command)
    if size.tabcolsep != 6.0:
        out.append(f"\\setlength{{\\tabcolsep}}{{{size.tabcolsep:g}pt}}")
    out += [r"\begin{tabular}{@{}l" + "r" * len(table.metrics) + "@{}}", r"\toprule"]
    first = True
    for line in _rows(table, size):
        if isinstance(line, str):
            out.append(r"\midrule")  # under the header, then between the groups
            out.append(f"\\multicolumn{{{ncols}}}{{@{{}}l}}{{\\textit{{{tex_escape(line)}}}}} \\\\")
            first = False
            continue
        out.append(" & ".join(c.tex for c in line).rstrip() + r" \\")
    if first:
        out.append(r"\midrule")
    out += [r"\bottomrule", r"\end{tabular}", f"\\end{{{env}}}"]
    return "\n".join(out) + "\n"


def _split(table: Table, target: float) -> list[Table]:
    """``table`` as tables of consecutive columns, each fitting ``target`` in the smallest
    type (a column too wide alone gets a table of its own)."""
    small = _SIZES[-1]
    parts: list[list[str]] = [[]]
    for name in table.metrics:
        trial = dataclasses.replace(table, metrics=(*parts[-1], name))
        if parts[-1] and _width(trial, small) > target:
            parts.append([name])
        else:
            parts[-1].append(name)
    return [dataclasses.replace(table, metrics=tuple(p)) for p in parts]


def latex_table(table: Table, width: LatexWidth = "single") -> str:
    """``table`` as LaTeX fitting ``width`` (see the module): one ``table`` / ``table*``
    environment, or several when the table had to be split."""
    if width == "single":
        targets = [(SINGLE_PT, "table", "fits a one-column article")]
    else:
        targets = [
            (COLUMN_PT, "table", "fits one column of a two-column article"),
            (SPAN_PT, "table*", "spans both columns of a two-column article"),
        ]
    for target, env, layout in targets:
        size = _fit(table, target)
        if size is not None:
            return _render(table, size, env, layout)
    target, env, layout = targets[-1]
    parts = _split(table, target)
    return "\n".join(
        _render(part, _fit(part, target) or _SIZES[-1], env, f"{layout}, split", i)
        for i, part in enumerate(parts)
    )
