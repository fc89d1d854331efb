"""CSV as people export it: encodings, delimiters, decimal commas, column names and units.

Every nav/ref/ranges CSV goes through :func:`read_table`: the bytes are decoded (a byte
order mark wins; else the encoding session.toml declares; else UTF-8), the delimiter is
sniffed from the header line (``,`` ``;`` tab ``|``, else whitespace), a ``;``/tab/``|``
file whose numbers use decimal commas is read as such, and then :func:`apply_form`
renames the columns that session.toml ``[columns]`` maps and converts the declared units
(ms, mm, rad, ...) to coopproc's (s, m, deg). Anything other than the plain form (UTF-8,
comma, coopproc's names and units) is said in a note. The session.toml side (parsing the
``[columns]`` table and the encoding keys of ``[files]``) is :mod:`coopproc.io.csv_mapping`.
"""

from __future__ import annotations

import codecs
import gzip
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.io._common import PARSE_ERRORS, Locator, missing_column, one_line, parser_error
from coopproc.io.csv_head import (
    HEAD_LINES,
    decimal_comma,
    head_lines,
    header_index,
    plain_head,
    sniff_delimiter,
    split_lines,
    text_lines,
)

__all__ = [
    "UNITS",
    "UNIT_COLUMNS",
    "CsvForm",
    "CsvTable",
    "apply_form",
    "decode_bytes",
    "read_table",
    "sniff_delimiter",
]

#: Unit keys of ``[columns.units]`` -> accepted units -> divisor to coopproc's unit
#: (``rad`` is converted to degrees, not divided).
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9},
    "range": {"m": 1.0, "cm": 1e2, "mm": 1e3},
    "position": {"m": 1.0, "cm": 1e2, "mm": 1e3, "km": 1e-3},
    "velocity": {"m/s": 1.0, "cm/s": 1e2, "mm/s": 1e3, "km/h": 3.6},
    "heading": {"deg": 1.0, "rad": 0.0},
}
#: coopproc's unit of each unit key (the first of its list).
BASE_UNITS: dict[str, str] = {key: next(iter(units)) for key, units in UNITS.items()}
#: The columns each unit key applies to (whichever the file has).
UNIT_COLUMNS: dict[str, tuple[str, ...]] = {
    "time": ("time",),
    "range": ("range", "sigma"),
    "position": (
        "east",
        "north",
        "up",
        "x",
        "y",
        "z",
        "height",
        "sigma_east",
        "sigma_north",
        "sigma_up",
    ),
    "velocity": ("vel_east", "vel_north", "vel_up"),
    "heading": ("heading",),
}

_BOMS: tuple[tuple[bytes, str, str], ...] = (
    (codecs.BOM_UTF32_LE, "utf-32", "UTF-32 (byte order mark)"),
    (codecs.BOM_UTF32_BE, "utf-32", "UTF-32 (byte order mark)"),
    (codecs.BOM_UTF8, "utf-8-sig", ""),
    (codecs.BOM_UTF16_LE, "utf-16", "UTF-16 (byte order mark)"),
    (codecs.BOM_UTF16_BE, "utf-16", "UTF-16 (byte order mark)"),
)


@dataclass(frozen=True)
class CsvForm:
    """How one CSV file is written: its encoding, column names and units."""

    #: Declared encoding (a Python codec name); None: UTF-8. A byte order mark wins.
    encoding: str | None = None
    #: Where the encoding was declared, for messages (``session.toml [files] encoding``).
    encoding_from: str = ""
    #: coopproc column name -> the column's name in the file.
    columns: Mapping[str, str] = field(default_factory=dict)
    #: Unit key (``time``, ``range``, ...) -> the file's unit, where not coopproc's.
    units: Mapping[str, str] = field(default_factory=dict)


@dataclass
class CsvTable:
    """A table as read: coopproc's column names and units, its row lines, its notes."""

    frame: pd.DataFrame
    where: Locator
    notes: list[str]


def decode_bytes(data: bytes, path: Path, form: CsvForm) -> tuple[str, str, str]:
    """The text of ``data``, what it was read as ('' for plain UTF-8) and the codec.

    A byte order mark (UTF-8, UTF-16, UTF-32) wins over a declared encoding. Bytes
    that do not decode are one InputError naming the line, column and byte.
    """
    label = ""
    encoding = "utf-8"
    for bom, codec, name in _BOMS:
        if data.startswith(bom):
            encoding, label = codec, name
            break
    else:
        if form.encoding is not None:
            encoding = form.encoding
            if codecs.lookup(encoding).name != "utf-8":
                label = f"{encoding} ({form.encoding_from or 'declared'})"
        wide = codecs.lookup(encoding).name.startswith(("utf-16", "utf-32"))
        if not wide and b"\x00" in data[:4096]:
            raise InputError(
                path,
                "holds NUL bytes: looks like UTF-16 or UTF-32 without a byte order mark; "
                'expected UTF-8, or the encoding in session.toml: [files] encoding = "utf-16-le"',
                line=1,
            )
    try:
        return data.decode(encoding), label, encoding
    except UnicodeDecodeError as err:
        head = data[: err.start].decode(encoding, errors="replace")
        line = head.count("\n") + 1
        column = len(head) - head.rfind("\n")
        bad = err.object[err.start : err.start + 1].hex()
        if label.startswith("UTF"):
            expected = f"{label.split(' ')[0]} text throughout, as its byte order mark says"
        elif form.encoding is not None:
            expected = f"text in {encoding} as {form.encoding_from or 'declared'} says"
        else:
            expected = (
                "UTF-8 text, or the file's encoding in session.toml, e.g. "
                '[files] encoding = "cp1252"'
            )
        raise InputError(
            path,
            f"byte 0x{bad} (column {column}) does not decode as {encoding} ({err.reason}); "
            f"expected {expected}",
            line=line,
        ) from err


def _is_number(text: str) -> bool:
    try:
        float(text.replace(",", "."))
    except ValueError:
        return False
    return True


def _check_header(
    path: Path, number: int, fields: Sequence[str], known: Sequence[str], expected: str
) -> None:
    """One clear error for a first line that holds values, not column names."""
    if not known or any(f in known for f in fields):
        return
    if any(_is_number(f) for f in fields):
        values = [one_line(f, 20) for f in fields if f]
        like = ", ".join(values[:3]) + (", ..." if len(values) > 3 else "")
        which = "first line" if number == 1 else "first line after the comments"
        raise InputError(
            path,
            f"{which} is not a header (found values like {like}); expected the header {expected}",
            line=number,
        )


def _check_widths(path: Path, lines: Sequence[str], header: int, width: int) -> None:
    """A whitespace-delimited row with fewer fields than the header would shift its cells."""
    for number, text in enumerate(lines[header + 1 :], start=header + 2):
        count = len(text.split())
        if 0 < count < width:
            raise InputError(
                path,
                f"{count} fields, expected {width} (whitespace-delimited: an empty cell "
                "shifts the ones after it; write NaN for a value not given)",
                line=number,
            )


def _reader(path: Path, form: CsvForm) -> Callable[[], list[str]]:
    """The decoded lines of ``path``, read again when an error message needs a line."""

    def read_lines() -> list[str]:
        data = path.read_bytes()
        if path.name.lower().endswith(".gz"):
            data = gzip.decompress(data)
        return split_lines(decode_bytes(data, path, form)[0])

    return read_lines


def read_table(
    path: Path,
    known: Sequence[str] = (),
    expected: str = "",
    form: CsvForm | None = None,
    *,
    required: Sequence[str] = (),
    text_columns: Sequence[str] = (),
    coded_columns: Sequence[str] = (),
) -> CsvTable:
    """A CSV table with ``#`` comments before its header, in coopproc's names and units.

    ``known``: coopproc's column names for this kind of file (the header should hold
    some; a first line that holds values names ``expected``). ``required``: columns a
    message should name by their mapped file name when missing. ``text_columns``:
    columns read as text (platform ids); ``coded_columns``: the same, read as pandas
    categories (text columns of millions of rows and a few distinct values: no string
    per row).
    """
    form = form or CsvForm()
    found = plain_head(path, form.encoding)
    if found is not None:  # plain ASCII, comma-delimited: the head is all that is needed
        text, lines, index = found
        encoding, codec = "", "utf-8"
    else:
        try:
            data = path.read_bytes()
            if path.name.lower().endswith(".gz"):
                data = gzip.decompress(data)
        except PARSE_ERRORS as err:
            raise InputError(
                path, f"cannot read as CSV ({type(err).__name__}: {one_line(err)})"
            ) from err
        text, encoding, codec = decode_bytes(data, path, form)  # bad bytes: one clear error
        del data
        lines = head_lines(text, HEAD_LINES)
        if not any(t.strip() and not t.strip().startswith("#") for t in lines[:-1]):
            lines = split_lines(text)  # a long comment block: look further
        index = header_index(lines, path)
    header = lines[index].strip()
    sep, sep_name = sniff_delimiter(header)
    fields = header.split() if sep == r"\s+" else header.split(sep)
    fields = [f.strip().strip('"') for f in fields]
    _check_header(path, index + 1, fields, known, expected)
    if sep == r"\s+":
        _check_widths(path, split_lines(text), index, len(fields))
    first_row = next((t for t in lines[index + 1 :] if t.strip()), "")
    del text
    decimal = "," if decimal_comma(first_row, sep) else "."
    as_text: dict[str, Any] = {form.columns.get(c, c): str for c in text_columns}
    as_text.update({form.columns.get(c, c): "category" for c in coded_columns})
    try:
        frame = pd.read_csv(
            path,  # the C engine reads a path several times faster than a StringIO
            encoding=codec,
            compression="gzip" if path.name.lower().endswith(".gz") else None,
            sep=sep,
            decimal=decimal,
            skiprows=index,
            skipinitialspace=True,
            dtype=as_text,
            engine="c",
            low_memory=False,
        )
    except pd.errors.ParserError as err:
        raise parser_error(path, err, "the header's columns") from err
    except PARSE_ERRORS as err:
        raise InputError(
            path, f"cannot read as CSV ({type(err).__name__}: {one_line(err)})"
        ) from err
    frame.columns = [str(c).strip() for c in frame.columns]
    if any(c.startswith("Unnamed:") for c in frame.columns):
        raise InputError(path, "a column has no name in the header", line=index + 1)
    where = Locator(str(path), lines=text_lines(_reader(path, form), index + 2))
    notes = []
    said = [encoding] if encoding else []
    if sep != ",":
        said.append(f"{sep_name}-delimited" + (" with decimal commas" if decimal == "," else ""))
    if said:
        notes.append(f"{path}: read as {', '.join(said)}")
    frame, more = apply_form(frame, form, where, known, required)
    return CsvTable(frame, where, notes + more)


def apply_form(
    frame: pd.DataFrame,
    form: CsvForm,
    where: Locator,
    known: Sequence[str],
    required: Sequence[str] = (),
) -> tuple[pd.DataFrame, list[str]]:
    """Rename the mapped columns of ``frame`` and convert its declared units (noted).

    Only mappings of ``known`` columns apply (a session-wide ``[columns] time`` serves
    nav and ranges alike). A mapped column the file lacks leaves the file's own column
    of that name, if any; a required one missing from both is an error naming both.
    """
    columns = [str(c) for c in frame.columns]
    rename: dict[str, str] = {}
    for name, given in form.columns.items():
        if name not in known or given == name:
            continue
        if given in columns:
            rename[given] = name
        elif name in required and name not in columns:
            err = missing_column(given, columns, where)
            raise InputError(
                where.path, err.problem.replace(f"'{given}'", f"'{given}' ([columns] {name})", 1)
            )
    # The file's own column of a mapped name goes, unless it is renamed itself (a swap).
    dropped = [n for n in rename.values() if n in columns and n not in rename]
    notes: list[str] = []
    if rename:
        frame = frame.drop(columns=dropped).rename(columns=rename)
        mapped = ", ".join(f"'{given}' as {name}" for given, name in rename.items())
        extra = f"; its own column(s) {', '.join(dropped)} ignored" if dropped else ""
        notes.append(f"{where.path}: session.toml [columns]: {mapped}{extra}")
    converted: list[str] = []
    for key, unit in sorted(form.units.items()):
        cols = [c for c in UNIT_COLUMNS[key] if c in frame.columns and c in known]
        if not cols or unit == BASE_UNITS[key]:
            continue
        frame = frame.copy() if not converted else frame
        for c in cols:
            frame[c] = _convert(frame[c], key, unit)
        converted.append(f"{', '.join(cols)} {unit} -> {BASE_UNITS[key]}")
    if converted:
        notes.append(f"{where.path}: units converted: {'; '.join(converted)}")
    return frame, notes


def _convert(column: pd.Series, key: str, unit: str) -> pd.Series:
    """``column`` in coopproc's unit; cells that are no number are left for the checks."""
    divisor = UNITS[key][unit]

    def scale(values: np.ndarray) -> np.ndarray:
        if key == "heading":
            return np.degrees(values)
        return values / divisor

    if pd.api.types.is_integer_dtype(column.dtype) and divisor == int(divisor) and divisor > 1:
        whole, rest = np.divmod(column.to_numpy(dtype=np.int64), int(divisor))
        return pd.Series(whole.astype(np.float64) + rest / divisor, index=column.index)
    if pd.api.types.is_numeric_dtype(column.dtype) and not pd.api.types.is_bool_dtype(column):
        return pd.Series(scale(column.to_numpy(dtype=np.float64)), index=column.index)
    number = pd.to_numeric(column, errors="coerce")
    scaled = pd.Series(scale(number.to_numpy(dtype=np.float64)), index=column.index)
    return column.where(number.isna(), scaled)
