r"""Fit a booktabs table to a page width: type size, ``table`` / ``table*``, split.

A :class:`Grid` is a table as cells (two header lines, body lines, full-width group lines);
:func:`render_grid` writes it as LaTeX for ``single`` (one-column article, a ``table`` at
most :data:`SINGLE_PT` wide: the article class's default text width; 2 cm margins give
483 pt) or ``double`` (a ``table`` at most :data:`COLUMN_PT` wide: one column of a
two-column A4 article, the narrowest usual column, IEEE's is 252 pt; else a ``table*``
across both columns, at most :data:`SPAN_PT`). Within its target the table takes the
largest type that fits, normal size, ``\small`` or ``\footnotesize`` (``\tabcolsep`` 6, 4,
3 pt), its width estimated from Computer Modern's character widths (2 % on the safe side;
tests/report/test_report_latex.py measures the real widths with pdflatex). A table too
wide even so is split into tables of consecutive columns, the first ``stub`` columns
repeated in each ("continued"). No ``\resizebox``: type never shrinks below footnote size.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "COLUMN_PT",
    "EN_DASH",
    "MINUS",
    "SINGLE_PT",
    "SPAN_PT",
    "THIN",
    "Cell",
    "Grid",
    "LatexWidth",
    "number_cell",
    "render_grid",
    "tex_escape",
    "text_cell",
]

LatexWidth = Literal["single", "double"]

#: \linewidth targets, pt: one-column article; one column / both columns of a two-column
#: A4 article (article class, 10 pt).
SINGLE_PT = 345.0
COLUMN_PT = 221.0
SPAN_PT = 452.0

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
#: Stand-ins in a cell's ``plain`` text: the math minus ``$-$``, the thin space ``\,``
#: and the en dash ``--``.
MINUS = "\u2212"
THIN = "\u2009"
EN_DASH = "\u2013"


def _text_width(text: str, bold: bool) -> float:
    """Width of ``text`` at 10 pt, pt (other characters: 10 pt, on the safe side)."""
    widths = _WIDTHS[bold]
    total = 0.0
    for char in text:
        code = ord(char)
        if 32 <= code < 127:
            total += widths[code - 32]
        else:
            total += {MINUS: 7.78, THIN: 1.67, EN_DASH: 5.0}.get(char, 10.0)
    return total


@dataclass(frozen=True)
class _Size:
    """A type size of the table: its command, scale against 10 pt, \\tabcolsep; the type of
    the small cells (the change rows)."""

    command: str
    scale: float
    tabcolsep: float
    small_command: str
    small_scale: float


_SIZES = (
    _Size("", 1.0, 6.0, r"\footnotesize", 0.85),
    _Size(r"\small", 0.925, 4.0, r"\scriptsize", 0.793),
    _Size(r"\footnotesize", 0.85, 3.0, r"\scriptsize", 0.793),
)


@dataclass(frozen=True)
class Cell:
    """One cell: its LaTeX, the text whose width it takes (``plain``, with :data:`MINUS`
    and :data:`THIN` for ``$-$`` and ``\\,``), bold, in the smaller type of change rows."""

    tex: str
    plain: str
    bold: bool = False
    small: bool = False

    def width(self, size: _Size) -> float:
        return _text_width(self.plain, self.bold) * (size.small_scale if self.small else size.scale)

    def latex(self, size: _Size) -> str:
        return f"{{{size.small_command} {self.tex}}}" if self.small and self.tex else self.tex


def tex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped."""
    out = []
    for char in text:
        if char == "\\":
            out.append(r"\textbackslash{}")
        elif char in "_%&#${}":
            out.append("\\" + char)
        elif char in "^~":
            out.append(f"\\{char}{{}}")
        else:
            out.append(char)
    return "".join(out)


def text_cell(text: str) -> Cell:
    """A cell of text."""
    return Cell(tex_escape(text), text)


def number_cell(text: str, bold: bool = False) -> Cell:
    """A printed number: minus as ``$-$``, ``-`` (undefined) as an en dash."""
    if text == "-":
        return Cell("--", "--")
    if text.startswith("-"):
        tex, plain = f"$-${text[1:]}", MINUS + text[1:]
    else:
        tex, plain = text, text
    return Cell(f"\\textbf{{{tex}}}" if bold else tex, plain, bold)


Line = tuple[Cell, ...] | str  # a row of cells, or a group label across the whole width


@dataclass(frozen=True)
class Grid:
    """A table as cells: ``tops`` / ``units`` the two header lines (``tops`` left out when
    all empty), ``lines`` the body; ``align`` one ``l`` / ``r`` per column; the first
    ``stub`` columns are repeated in each part of a split table. ``caption`` is LaTeX."""

    key: str
    title: str
    caption: str
    align: str
    tops: tuple[Cell, ...]
    units: tuple[Cell, ...]
    lines: tuple[Line, ...]
    stub: int = 1

    def columns(self, keep: Sequence[int]) -> Grid:
        """The grid with the columns ``keep`` only (indices, in order)."""

        def pick(cells: tuple[Cell, ...]) -> tuple[Cell, ...]:
            return tuple(cells[i] for i in keep)

        lines = tuple(line if isinstance(line, str) else pick(line) for line in self.lines)
        align = "".join(self.align[i] for i in keep)
        return dataclasses.replace(
            self, align=align, tops=pick(self.tops), units=pick(self.units), lines=lines
        )


def _width(grid: Grid, size: _Size) -> float:
    """Estimated width of the tabular, pt (``@{}`` at both ends)."""
    cols = [0.0] * len(grid.align)
    group = 0.0
    for line in (grid.tops, grid.units, *grid.lines):
        if isinstance(line, str):
            group = max(group, _text_width(line, False) * size.scale)
            continue
        for i, cell in enumerate(line):
            cols[i] = max(cols[i], cell.width(size))
    total = sum(cols) + 2 * size.tabcolsep * (len(cols) - 1)
    return max(total, group) * 1.02 + 1.0  # on the safe side of the estimate


def _fit(grid: Grid, target: float) -> _Size | None:
    return next((s for s in _SIZES if _width(grid, s) <= target), None)


def _render(grid: Grid, size: _Size, env: str, layout: str, part: int = 0) -> str:
    label = grid.key if not part else f"{grid.key}-{part + 1}"
    caption = grid.caption if not part else f"{grid.caption.rstrip('.')} (continued)."
    out = [
        f"% {grid.title}{' (continued)' if part else ''}",
        f"% needs \\usepackage{{booktabs}}; {layout}, about {_width(grid, size):.0f} pt wide",
        f"\\begin{{{env}}}[htbp]",
        r"\centering",
        f"\\caption{{{caption}}}",
        f"\\label{{tab:{label}}}",
    ]
    if size.command:
        out.append(size.command)
    if size.tabcolsep != 6.0:
        out.append(f"\\setlength{{\\tabcolsep}}{{{size.tabcolsep:g}pt}}")
    out += [f"\\begin{{tabular}}{{@{{}}{grid.align}@{{}}}}", r"\toprule"]
    heads = [grid.units] if not any(c.plain for c in grid.tops) else [grid.tops, grid.units]
    body: list[Line | None] = [*heads, None, *grid.lines]  # None: the rule under the header
    ruled = True
    for line in body:
        if line is None:
            out.append(r"\midrule")
        elif isinstance(line, str):
            if not ruled:
                out.append(r"\midrule")  # between groups
            ncols = len(grid.align)
            out.append(f"\\multicolumn{{{ncols}}}{{@{{}}l}}{{\\textit{{{tex_escape(line)}}}}} \\\\")
        else:
            out.append(" & ".join(c.latex(size) for c in line).rstrip() + r" \\")
        ruled = line is None
    out += [r"\bottomrule", r"\end{tabular}", f"\\end{{{env}}}"]
    return "\n".join(out) + "\n"


def _split(grid: Grid, target: float) -> list[Grid]:
    """Parts of consecutive columns (after the stub), each fitting ``target`` in the
    smallest type, as even in their number of columns as that allows; a column too wide
    alone gets a part of its own."""
    stub = list(range(grid.stub))
    rest = list(range(grid.stub, len(grid.align)))
    parts: list[list[int]] = [[]]
    for i in rest:  # greedy: the fewest parts
        if parts[-1] and _width(grid.columns([*stub, *parts[-1], i]), _SIZES[-1]) > target:
            parts.append([i])
        else:
            parts[-1].append(i)
    k = len(parts)
    even = [rest[len(rest) * j // k : len(rest) * (j + 1) // k] for j in range(k)]
    if all(_width(grid.columns([*stub, *p]), _SIZES[-1]) <= target for p in even):
        parts = even
    return [grid.columns([*stub, *p]) for p in parts]


def render_grid(grid: Grid, width: LatexWidth = "single") -> str:
    """``grid`` as LaTeX fitting ``width`` (see the module): one ``table`` / ``table*``, or
    several when it had to be split."""
    if width == "single":
        targets = [(SINGLE_PT, "table", "fits a one-column article")]
    else:
        targets = [
            (COLUMN_PT, "table", "fits one column of a two-column article"),
            (SPAN_PT, "table*", "spans both columns of a two-column article"),
        ]
    for target, env, layout in targets:
        size = _fit(grid, target)
        if size is not None:
            return _render(grid, size, env, layout)
    target, env, layout = targets[-1]
    return "\n".join(
        _render(part, _fit(part, target) or _SIZES[-1], env, f"{layout}, split", i)
        for i, part in enumerate(_split(grid, target))
    )
