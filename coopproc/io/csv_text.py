"""Text cells of the compiled CSV writer (:mod:`coopproc.io.csv_fast`): every distinct
text of a table quoted once by the :mod:`csv` module, and each text column as integer
codes into that table (a categorical column by its own small codes, widened a chunk at a
time)."""

from __future__ import annotations

import csv
import io
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ShiftedCodes", "TextCells", "category_codes", "quoted", "text_codes"]


def quoted(texts: list[str]) -> list[bytes]:
    """Each text as the csv module writes it inside a row (quoted when it must be)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    out = []
    for text in texts:
        buffer.seek(0)
        buffer.truncate()
        writer.writerow([text, ""])
        out.append(buffer.getvalue()[:-2].encode("utf-8"))
    return out


class TextCells:
    """The distinct text cells of a table: codes into one byte table."""

    def __init__(self) -> None:
        self.cells: list[bytes] = []

    def add(self, texts: list[bytes]) -> int:
        """Append ``texts``; the code of the first."""
        first = len(self.cells)
        self.cells += texts
        return first

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        table = np.frombuffer(b"".join(self.cells) or b"\0", dtype=np.uint8)
        bounds = np.zeros(len(self.cells) + 1, dtype=np.int64)
        np.cumsum([len(t) for t in self.cells], out=bounds[1:])
        return table, bounds


class ShiftedCodes:
    """A categorical column's own small codes (int8 for a few categories), made int64
    codes into the table's texts a chunk at a time (not 8 bytes per row of a day's table
    at once)."""

    def __init__(self, codes: np.ndarray, first: int) -> None:
        self.codes = codes
        self.first = first

    def __len__(self) -> int:
        return len(self.codes)

    def __getitem__(self, rows: slice) -> np.ndarray:
        part = self.codes[rows].astype(np.int64)
        part[part >= 0] += self.first
        return part


def category_codes(column: pd.Series, texts: TextCells) -> tuple[ShiftedCodes, int] | None:
    """Codes of a categorical text column (see ShiftedCodes); None if not text."""
    labels = list(column.cat.categories)
    if not all(isinstance(u, str) and "\0" not in u for u in labels):
        return None
    cells = quoted(labels)
    first = texts.add(cells)
    return ShiftedCodes(column.cat.codes.to_numpy(), first), max([0, *(len(t) for t in cells)])


def text_codes(column: pd.Series, texts: TextCells) -> tuple[Any, int] | None:
    """Codes of a text column (-1: missing) and its longest cell; None if not text."""
    import pandas as pd

    if isinstance(column.dtype, pd.CategoricalDtype):
        return category_codes(column, texts)
    # the column's own factorize: pyarrow's dictionary encoding for a pyarrow-backed str
    codes, uniques = column.factorize(use_na_sentinel=True)
    labels = list(uniques)
    if not all(isinstance(u, str) and "\0" not in u for u in labels):
        return None
    cells = quoted(labels)
    first = texts.add(cells)
    codes = codes.astype(np.int64)
    codes[codes >= 0] += first
    return codes, max([0, *(len(t) for t in cells)])
