"""Compile LaTeX tables with pdflatex and measure each tabular against \\linewidth.

Used by tests/report/test_report_latex.py (skipped without pdflatex) and by hand:
``python tests/report/latex_measure.py TABLES.tex`` prints the widths in each document.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

#: The documents the tables are measured in: name -> preamble.
DOCUMENTS = {
    "article": r"\documentclass{article}",
    "article-2cm": r"\documentclass[a4paper]{article}\usepackage[margin=2cm]{geometry}",
    "twocolumn": r"\documentclass[twocolumn]{article}",
    "twocolumn-a4": r"\documentclass[a4paper,twocolumn]{article}",
}

_MARK = re.compile(r"WIDTH=([0-9.]+)pt\s*LINEWIDTH=([0-9.]+)pt LABEL=(\S*)")


@dataclass(frozen=True)
class Measured:
    """One tabular: its label, its width and the \\linewidth of its float, pt."""

    label: str
    width: float
    linewidth: float


@dataclass(frozen=True)
class Compiled:
    """The measured tabulars of one document and its Overfull \\hbox warnings."""

    tables: list[Measured]
    overfull: list[str]


def pdflatex() -> str | None:
    """The pdflatex executable, or None."""
    return shutil.which("pdflatex")


def instrument(tables_tex: str) -> str:
    """Each tabular boxed, its width and \\linewidth written to the log; a page break
    after each table (no float pile-up)."""
    out = []
    label = ""
    for line in tables_tex.splitlines():
        found = re.match(r"\\label\{(.*)\}", line)
        if found:
            label = found.group(1)
        if line.startswith(r"\begin{tabular}"):
            line = r"\sbox0{" + line
        if line == r"\end{tabular}":
            line = (
                r"\end{tabular}}\typeout{WIDTH=\the\wd0\space LINEWIDTH=\the\linewidth"
                rf"\space LABEL={label}}}\usebox0"
            )
        out.append(line)
        if line.startswith(r"\end{table"):
            out.append(r"\clearpage")
    return "\n".join(out) + "\n"


def compile_tables(tables_tex: str, preamble: str, workdir: Path | None = None) -> Compiled:
    """Compile ``tables_tex`` (the report's LaTeX) after ``preamble`` with booktabs."""
    exe = pdflatex()
    if exe is None:
        raise RuntimeError("pdflatex is not installed")
    with tempfile.TemporaryDirectory() as tmp:
        where = workdir or Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        doc = where / "tables.tex"
        doc.write_text(
            preamble
            + "\n\\usepackage{booktabs}\n\\begin{document}\n"
            + instrument(tables_tex)
            + "\\end{document}\n"
        )
        result = subprocess.run(
            [exe, "-interaction=nonstopmode", "-halt-on-error", doc.name],
            cwd=where,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        log = (where / "tables.log").read_text(errors="replace")
        if result.returncode != 0:
            raise RuntimeError(f"pdflatex failed:\n{log[-3000:]}")
    tables = [Measured(m[2], float(m[0]), float(m[1])) for m in _MARK.findall(log)]
    overfull = [line for line in log.splitlines() if line.startswith("Overfull \\hbox")]
    return Compiled(tables, overfull)


if __name__ == "__main__":
    text = Path(sys.argv[1]).read_text()
    for name, preamble in DOCUMENTS.items():
        compiled = compile_tables(text, preamble)
        for t in compiled.tables:
            flag = "" if t.width <= t.linewidth else f"  TOO WIDE by {t.width - t.linewidth:.1f}"
            print(f"{name:13s} {t.label:28s} {t.width:7.1f} / {t.linewidth:6.1f} pt{flag}")
        for line in compiled.overfull:
            print(f"{name:13s} {line}")
