"""Where a CSV text's header is and how its rows are split: what :func:`read_table
<coopproc.io.csv_forms.read_table>` looks at before the C reader parses the rows.

The delimiter is sniffed from the header line; only the first lines of a text are looked
at, and a large plain-ASCII file is checked in chunks instead of decoded whole
(:func:`plain_head`).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path

from coopproc.errors import InputError

__all__ = [
    "HEAD_LINES",
    "decimal_comma",
    "head_lines",
    "header_index",
    "plain_head",
    "sniff_delimiter",
    "split_lines",
    "text_lines",
]

_CANDIDATES = ((",", "','"), (";", "';'"), ("\t", "tab"), ("|", "'|'"))
_DECIMAL_COMMA = re.compile(r"\A[+-]?\d+,\d+([eE][+-]?\d+)?\Z")
_DECIMAL_POINT = re.compile(r"\A[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?\Z")


def sniff_delimiter(header: str) -> tuple[str, str]:
    """The delimiter of a header line and its name: the candidate giving most fields.

    Ties go to ``,`` then ``;``, tab, ``|``; a header none of these splits is split on
    whitespace (``\\s+``) when that gives two or more fields, else read as one column.
    """
    best, name, most = ",", "','", 1
    for sep, label in _CANDIDATES:
        count = len(header.split(sep))
        if count > most:
            best, name, most = sep, label, count
    if most == 1 and len(header.split()) >= 2:
        return r"\s+", "whitespace"
    return best, name


def decimal_comma(row: str, sep: str) -> bool:
    """Whether a data row written with ``sep`` uses decimal commas (``1,5``)."""
    if sep == ",":
        return False
    fields = row.split() if sep == r"\s+" else row.split(sep)
    fields = [f.strip().strip('"') for f in fields]
    return any(_DECIMAL_COMMA.match(f) for f in fields) and not any(
        _DECIMAL_POINT.match(f) for f in fields
    )


def header_index(lines: Sequence[str], path: Path) -> int:
    """0-based index of the header line (after ``#`` comments and blank lines)."""
    for index, text in enumerate(lines):
        stripped = text.strip()
        if stripped and not stripped.startswith("#"):
            return index
    raise InputError(path, "empty file; expected a header line and data rows")


def split_lines(text: str) -> list[str]:
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def head_lines(text: str, count: int) -> list[str]:
    """The first ``count`` lines of ``text`` (all of them if fewer), split as
    :func:`split_lines` does, without splitting the whole (large) text."""
    end = 0
    for _ in range(count):
        found = text.find("\n", end)
        if found < 0:
            return split_lines(text)
        end = found + 1
    return split_lines(text[:end])[:-1]


def text_lines(read_lines: Callable[[], list[str]], first_data_line: int) -> Callable[[int], int]:
    """Map data row index -> 1-based line of the decoded text, skipping blank lines.

    ``read_lines`` gives the text's lines; it is called on the first lookup only (an
    error message), so a large file's lines are not held in memory."""
    cache: list[int] = []

    def line_of(row: int) -> int:
        if not cache:
            lines = read_lines()
            cache.extend(
                n
                for n, text in enumerate(lines[first_data_line - 1 :], start=first_data_line)
                if text.strip()
            )
        return cache[row] if row < len(cache) else first_data_line + row

    return line_of


#: Lines looked at for the header and the first row (the rest is left to the C reader).
HEAD_LINES = 1000


#: Bytes read at a time when checking that a file is plain ASCII.
_CHUNK = 1 << 23


def plain_head(path: Path, encoding: str | None) -> tuple[str, list[str], int] | None:
    """(head text, its first lines, the header's index) of a file that
    :func:`coopproc.io.csv_forms.read_table` reads exactly as from its whole decoded
    text: plain ASCII (so valid UTF-8, no byte order mark), no NUL in its first 4096
    bytes, no declared encoding, not gzip, its header within the first lines and not
    whitespace-delimited (``encoding``: the one its :class:`~coopproc.io.csv_forms.CsvForm`
    declares). None otherwise (the caller decodes the whole file). The file is checked
    in chunks, so its text is never held whole."""
    if encoding is not None or path.name.lower().endswith(".gz"):
        return None
    try:
        with open(path, "rb") as fh:
            head = fh.read(_CHUNK)
            if b"\x00" in head[:4096] or not head.isascii():
                return None
            whole = len(head) < _CHUNK
            if not whole and head.count(b"\n") < HEAD_LINES:
                return None  # long lines: the head may not hold the lines looked at
            while chunk := fh.read(_CHUNK):
                if not chunk.isascii():
                    return None
    except OSError:
        return None  # the caller reports it
    text = head.decode("ascii")
    lines = head_lines(text, HEAD_LINES)
    if not any(t.strip() and not t.strip().startswith("#") for t in lines[:-1]):
        return None
    index = header_index(lines, path)
    if sniff_delimiter(lines[index].strip())[0] == r"\s+":
        return None
    return text, lines, index
