"""A session's ranges file as text, changed row by row (``coopproc inject``).

The new ``ranges.csv`` is the original file with some ``range`` cells changed and some
rows left out: comment lines, the header, every other column (extra ones included), the
other rows, the line ends and the compression stay as they were. A changed cell is the
exact decimal sum of the original cell and the added error (rounded to the micrometre,
as ``injected.csv`` records it), so ``new - old`` in the files is exactly the recorded
error. The file was validated by the session reader before, so its rows parse.
"""

from __future__ import annotations

import csv
import gzip
import io
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

import numpy as np

from coopproc.errors import InputError
from coopproc.model import FloatArray, pair_name

__all__ = ["RangesText", "add_decimal", "read_ranges_text", "write_ranges_text"]


@dataclass(frozen=True)
class RangesText:
    """The lines of a ranges file and its data rows (in file order)."""

    lines: tuple[str, ...]
    #: line index of each data row
    rows: tuple[int, ...]
    range_column: int
    time_s: FloatArray
    pair: np.ndarray
    range_text: tuple[str, ...]


def _open_text(path: Path) -> str:
    raw = path.read_bytes()
    if path.name.endswith(".gz"):
        raw = gzip.decompress(raw)
    return raw.decode("utf-8")


def _fields(line: str) -> list[str]:
    return next(csv.reader([line.rstrip("\r\n")], skipinitialspace=True))


def read_ranges_text(path: Path) -> RangesText:
    """Parse a (validated) ranges file: its lines, rows, times, pairs and range cells."""
    try:
        # universal line ends, each line keeping its own ("\r\n" stays "\r\n")
        lines = tuple(io.StringIO(_open_text(path), newline="").readlines())
    except (OSError, UnicodeError, EOFError, gzip.BadGzipFile) as err:
        raise InputError(path, f"cannot read ({err})") from err
    header = next(
        (i for i, text in enumerate(lines) if text.strip() and not text.strip().startswith("#")),
        None,
    )
    if header is None:
        raise InputError(path, "no header line; expected time,from,to,range")
    names = [f.strip() for f in _fields(lines[header])]
    index = {name: names.index(name) for name in ("time", "from", "to", "range") if name in names}
    if len(index) < 4:
        raise InputError(path, "header lacks time, from, to or range", line=header + 1)
    rows, times, pairs, cells = [], [], [], []
    for i in range(header + 1, len(lines)):
        if not lines[i].strip():
            continue
        fields = _fields(lines[i])
        try:
            times.append(float(fields[index["time"]]))
            pairs.append(pair_name(fields[index["from"]].strip(), fields[index["to"]].strip()))
            cells.append(fields[index["range"]].strip())
        except (IndexError, ValueError) as err:
            raise InputError(path, f"cannot read the row ({err})", line=i + 1) from err
        rows.append(i)
    return RangesText(
        lines=lines,
        rows=tuple(rows),
        range_column=index["range"],
        time_s=np.asarray(times, dtype=np.float64),
        pair=np.asarray(pairs, dtype=object),
        range_text=tuple(cells),
    )


def add_decimal(cell: str, added_m: float) -> str:
    """``cell + added_m`` in exact decimal arithmetic, ``added_m`` rounded to 1e-6 m."""
    total = Decimal(cell) + Decimal(f"{added_m:.6f}")
    return format(total, "f")


def _replace_cell(line: str, column: int, text: str) -> str:
    body = line.rstrip("\r\n")
    ending = line[len(body) :]
    if '"' not in body:
        parts = body.split(",")
        cell = parts[column]
        lead = cell[: len(cell) - len(cell.lstrip())]
        trail = cell[len(cell.rstrip()) :]
        parts[column] = lead + text + trail
        return ",".join(parts) + ending
    fields = _fields(body)
    fields[column] = text
    buf = io.StringIO()
    csv.writer(buf, lineterminator=ending or "\n").writerow(fields)
    return buf.getvalue()


def write_ranges_text(
    table: RangesText, path: Path, new_cells: Mapping[int, str], removed: set[int]
) -> Path:
    """Write the file with data row ``k``'s range cell replaced by ``new_cells[k]`` and
    the data rows in ``removed`` left out (``.gz``: gzip without a timestamp)."""
    lines = list(table.lines)
    for k, text in new_cells.items():
        i = table.rows[k]
        lines[i] = _replace_cell(lines[i], table.range_column, text)
    for k in removed:
        lines[table.rows[k]] = ""
    data = "".join(lines).encode("utf-8")
    if path.name.endswith(".gz"):
        buf = io.BytesIO()
        with gzip.GzipFile(filename="", mode="wb", fileobj=buf, mtime=0) as gz:
            gz.write(data)
        data = buf.getvalue()
    path.write_bytes(data)
    return path
