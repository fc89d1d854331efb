"""Compiled CSV text of a table, byte for byte what pandas writes with ``"%.6f"``.

``pandas.DataFrame.to_csv(index=False, float_format="%.6f", lineterminator="\\n")``
formats every float with one Python call; on a day of logs that was most of the time
spent writing the outputs. :func:`csv_chunks` makes the same bytes in a numba kernel:

- floats: ``"%.6f"`` is the correctly rounded decimal of the binary double, ties to even.
  ``y = x * 1e6`` is rounded once; its exact value is ``y + err`` (Dekker's exact
  product: ``err`` from the split of ``x`` into two 26-bit halves), which decides the
  cases where ``y`` lies exactly halfway between two integers (``0.0078125``). Negative
  values keep their sign when they round to zero (``-0.000000``), NaN is an empty cell,
  infinities are ``inf``/``-inf``; magnitudes of 4e9 and more (where ``y`` has no
  fraction bits left) are formatted by Python, as text cells;
- integers as ``str`` writes them, booleans ``True``/``False``;
- text (``str`` or ``object`` columns of strings; missing values are empty cells):
  quoted by the :mod:`csv` module itself, once per distinct value (:mod:`coopproc.io.csv_text`).

A table the kernel cannot match exactly (another column type, non-text column labels,
fewer than two columns, a NUL character in a text) gives ``None``; the caller then
writes it with pandas.
"""

from __future__ import annotations

import csv
import io
from collections import deque
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from coopproc.io.csv_text import TextCells, text_codes

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["CHUNK_ROWS", "FAST_LIMIT", "csv_bytes", "csv_chunks", "round_like_csv", "row_pieces"]

#: Rows formatted at once (bounds the memory of a chunk's text).
CHUNK_ROWS = 1 << 16
#: Chunks formatted ahead of the one being written, each in a thread of its own.
AHEAD = 2
#: Magnitudes below this are formatted by the kernel (``|x| * 1e6 < 2**52``).
FAST_LIMIT = 4.0e9
_FLOAT, _INT, _TEXT = 0, 1, 2
#: Most bytes of a kernel float cell (``-3999999999.999999``) and of an int64 cell.
_FLOAT_WIDTH, _INT_WIDTH = 18, 20


#: "00" ... "99": two ASCII digits per number.
_PAIRS = np.frombuffer(b"".join(b"%02d" % i for i in range(100)), dtype=np.uint8).copy()


@numba.njit(cache=True)
def _put_uint(value: int | np.int64, out: np.ndarray, pos: int) -> int:  # pragma: no cover - jit
    """Decimal digits of ``value`` (0 <= value < 2**63) at ``out[pos:]``; the position
    after them."""
    v = np.uint64(value)
    hundred = np.uint64(100)
    count = 1
    bound = np.uint64(10)
    while count < 19 and v >= bound:
        count += 1
        bound *= np.uint64(10)
    k = pos + count
    while v >= hundred:
        q = v // hundred
        r = 2 * np.intp(v - q * hundred)
        k -= 2
        out[k] = _PAIRS[r]
        out[k + 1] = _PAIRS[r + 1]
        v = q
    if v >= np.uint64(10):
        r = 2 * np.intp(v)
        out[k - 2] = _PAIRS[r]
        out[k - 1] = _PAIRS[r + 1]
    else:
        out[k - 1] = 48 + np.intp(v)
    return pos + count


@numba.njit(cache=True)
def _scaled(x: float) -> np.int64:  # pragma: no cover - jit
    """``x * 1e6`` rounded to an integer as ``"%.6f"`` rounds (finite ``|x| < FAST_LIMIT``)."""
    y = x * 1e6
    c = x * 134217729.0  # 2**27 + 1
    high = c - (c - x)
    err = (high * 1e6 - y) + (x - high) * 1e6  # x * 1e6 == y + err exactly
    lower = np.floor(y)
    frac = y - lower  # exact: |y| < 2**52
    up = frac > 0.5 or (frac == 0.5 and (err > 0 or (err == 0 and lower % 2 != 0)))
    return np.int64(lower) + (1 if up else 0)


@numba.njit(cache=True)
def _put_float(x: float, out: np.ndarray, pos: int) -> int:  # pragma: no cover - jit
    """``"%.6f" % x`` for a finite ``|x| < FAST_LIMIT`` at ``out[pos:]``."""
    scaled = _scaled(x)
    if np.signbit(x):
        out[pos] = 45  # "-" also for -0.0 and for what rounds to zero
        pos += 1
    magnitude = scaled if scaled >= 0 else -scaled
    whole = magnitude // 1000000
    pos = _put_uint(whole, out, pos)
    out[pos] = 46  # "."
    rest = magnitude - whole * 1000000
    high2 = rest // 10000
    mid = rest // 100 - high2 * 100
    low = rest - (rest // 100) * 100
    out[pos + 1] = _PAIRS[2 * high2]
    out[pos + 2] = _PAIRS[2 * high2 + 1]
    out[pos + 3] = _PAIRS[2 * mid]
    out[pos + 4] = _PAIRS[2 * mid + 1]
    out[pos + 5] = _PAIRS[2 * low]
    out[pos + 6] = _PAIRS[2 * low + 1]
    return pos + 7


@numba.njit(cache=True, nogil=True)
def _format_rows(
    rows: int,
    kinds: np.ndarray,
    slots: np.ndarray,
    floats: np.ndarray,
    ints: np.ndarray,
    codes: np.ndarray,
    table: np.ndarray,
    bounds: np.ndarray,
    out: np.ndarray,
    ends: np.ndarray,
) -> int:  # pragma: no cover - jit
    """Rows of CSV text into ``out``; the number of bytes written.

    Column ``j`` is ``floats[slots[j]]``, ``ints[slots[j]]`` or ``codes[slots[j]]`` by
    ``kinds[j]``; text code ``c`` is ``table[bounds[c]:bounds[c + 1]]``, -1 empty.
    ``ends[i]``: where row ``i`` ends in ``out``.
    """
    pos = 0
    for i in range(rows):
        for j in range(kinds.size):
            if j:
                out[pos] = 44  # ","
                pos += 1
            slot = slots[j]
            if kinds[j] == 0:
                x = floats[slot, i]
                if np.isnan(x):
                    continue
                if np.isinf(x):
                    if x < 0:
                        out[pos] = 45
                        pos += 1
                    out[pos] = 105  # "inf"
                    out[pos + 1] = 110
                    out[pos + 2] = 102
                    pos += 3
                    continue
                pos = _put_float(x, out, pos)
            elif kinds[j] == 1:
                v = ints[slot, i]
                if v < 0:  # never the int64 minimum (csv_chunks)
                    out[pos] = 45
                    pos += 1
                    v = -v
                pos = _put_uint(v, out, pos)
            else:
                c = codes[slot, i]
                if c >= 0:
                    for b in range(bounds[c], bounds[c + 1]):
                        out[pos] = table[b]
                        pos += 1
        out[pos] = 10  # "\n"
        pos += 1
        ends[i] = pos
    return pos


@numba.njit(cache=True)
def _round_kernel(x: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - jit
    for i in range(x.size):
        v = x[i]
        if np.isfinite(v) and abs(v) < FAST_LIMIT:
            scaled = _scaled(v)
            # n / 1e6 (both exact) is the double nearest to the decimal n * 1e-6
            out[i] = np.copysign(scaled / 1e6, v) if scaled == 0 else scaled / 1e6
        else:
            out[i] = v


def round_like_csv(values: np.ndarray) -> np.ndarray:
    """The doubles a CSV reader gets back from the ``"%.6f"`` text of ``values``
    (NaN and the infinities unchanged; ``-0.000000`` is -0.0)."""
    x = np.ascontiguousarray(values, dtype=np.float64)
    out = np.empty_like(x)
    _round_kernel(x.reshape(-1), out.reshape(-1))
    slow = np.flatnonzero(np.isfinite(x) & ~(np.abs(x) < FAST_LIMIT))
    if len(slow):
        out.reshape(-1)[slow] = [float(f"{v:.6f}") for v in x.reshape(-1)[slow].tolist()]
    return out


@numba.njit(cache=True, nogil=True)
def _any_slow(x: np.ndarray) -> bool:  # pragma: no cover - jit
    """Whether a finite value of ``x`` has a magnitude the kernel does not take."""
    for v in x:  # noqa: SIM110 - a compiled loop that stops at the first
        if np.isfinite(v) and not abs(v) < FAST_LIMIT:
            return True
    return False


def _slow_floats(x: np.ndarray, texts: TextCells) -> tuple[np.ndarray, int] | None:
    """A float column with magnitudes the kernel does not take, as text codes."""
    if not _any_slow(x):
        return None
    cells = [b"" if np.isnan(v) else b"%.6f" % v for v in x.tolist()]
    codes = np.arange(len(cells), dtype=np.int64) + texts.add(cells)
    codes[np.isnan(x)] = -1
    return codes, max(len(t) for t in cells)


def row_pieces(
    frame: pd.DataFrame, chunk_rows: int
) -> Iterator[tuple[memoryview, np.ndarray]] | None:
    """The CSV text of ``frame`` as (text, where each row ends in it): the header, then
    the rows ``chunk_rows`` at a time, each piece valid until the next one is asked for;
    None when the kernel cannot match pandas for the table (module doc)."""
    import pandas as pd

    labels = list(frame.columns)
    if len(labels) < 2 or not all(isinstance(c, str) for c in labels):
        return None
    columns: list[tuple[int, Any]] = []  # (kind, values)
    for j in range(len(labels)):
        column = frame.iloc[:, j]
        dtype = column.dtype
        if isinstance(dtype, pd.StringDtype | pd.CategoricalDtype) or dtype == np.dtype(object):
            columns.append((_TEXT, column))
            continue
        values = column.to_numpy()
        if isinstance(dtype, np.dtype) and dtype.kind == "f":
            columns.append((_FLOAT, values.astype(np.float64, copy=False)))
        elif isinstance(dtype, np.dtype) and dtype.kind in "iu":
            limit = np.iinfo(np.int64)
            if len(values) and (values.max() > limit.max or values.min() == limit.min):
                return None
            columns.append((_INT, values.astype(np.int64, copy=False)))
        elif isinstance(dtype, np.dtype) and dtype.kind == "b":
            columns.append((_TEXT, values))
        else:
            return None
    header = io.StringIO()
    csv.writer(header, lineterminator="\n").writerow(labels)
    texts = TextCells()
    kinds, widths = [], []
    plan: list[list[np.ndarray]] = [[], [], []]
    for kind, values in columns:
        if kind == _TEXT and values.dtype == np.dtype(bool):
            codes = values.astype(np.int64) + texts.add([b"False", b"True"])
            coded: tuple[np.ndarray, int] | None = (codes, 5)
        elif kind == _TEXT:
            coded = text_codes(values, texts)
            if coded is None:
                return None
        else:
            coded = _slow_floats(values, texts) if kind == _FLOAT else None
        if coded is not None:
            kind, values, width = _TEXT, coded[0], coded[1]
        else:
            width = _FLOAT_WIDTH if kind == _FLOAT else _INT_WIDTH
        kinds.append(kind)
        widths.append(width)
        plan[kind].append(values)
    slots = [sum(1 for k in kinds[:j] if k == kind) for j, kind in enumerate(kinds)]
    return _pieces(
        header.getvalue().encode("utf-8"),
        (np.array(kinds, dtype=np.int64), np.array(slots, dtype=np.int64)),
        plan,
        texts.arrays(),
        len(frame),
        sum(widths) + len(widths),
        chunk_rows,
    )


def _stacked(columns: list[np.ndarray], rows: slice, dtype: type) -> np.ndarray:
    """The ``rows`` of ``columns`` as one (len(columns), n) array."""
    if not columns:
        return np.zeros((0, 0), dtype=dtype)
    return np.stack([c[rows] for c in columns])


def _pieces(
    header: bytes,
    layout: tuple[np.ndarray, np.ndarray],
    plan: list[list[np.ndarray]],
    text: tuple[np.ndarray, np.ndarray],
    rows: int,
    row_width: int,
    chunk_rows: int,
) -> Iterator[tuple[memoryview, np.ndarray]]:
    """The header, then the rows chunk by chunk: (text, where each row ends in it).

    The next :data:`AHEAD` chunks are formatted in as many threads (the kernel releases
    the GIL) while the caller writes this one; ``AHEAD + 1`` buffers take turns (two
    formatting threads: 4 M positions rows 2.66 -> 1.7 s on this 2-core machine).
    """
    yield memoryview(header), np.array([len(header)], dtype=np.int64)
    if rows == 0:
        return
    n = min(rows, chunk_rows)
    buffers = [(np.empty(row_width * n, np.uint8), np.empty(n, np.int64)) for _ in range(AHEAD + 1)]

    def format_chunk(start: int, k: int) -> tuple[int, int]:
        s = slice(start, min(rows, start + chunk_rows))
        out, ends = buffers[k % (AHEAD + 1)]
        size = _format_rows(
            s.stop - s.start,
            *layout,
            _stacked(plan[_FLOAT], s, np.float64),
            _stacked(plan[_INT], s, np.int64),
            _stacked(plan[_TEXT], s, np.int64),
            *text,
            out,
            ends,
        )
        return size, s.stop - s.start

    starts = range(0, rows, chunk_rows)
    with ThreadPoolExecutor(max_workers=AHEAD) as pool:
        pending = deque(
            pool.submit(format_chunk, starts[k], k) for k in range(AHEAD) if k < len(starts)
        )
        for k in range(len(starts)):
            size, count = pending.popleft().result()
            if k + AHEAD < len(starts):  # into the buffer the caller has written
                pending.append(pool.submit(format_chunk, starts[k + AHEAD], k + AHEAD))
            out, ends = buffers[k % (AHEAD + 1)]
            yield out[:size].data, ends[:count]


def csv_chunks(frame: pd.DataFrame, chunk_rows: int = CHUNK_ROWS) -> Iterator[memoryview] | None:
    """The UTF-8 CSV text of ``frame`` in pieces (header first), as pandas writes it with
    ``index=False, float_format="%.6f", lineterminator="\\n"``; None when this module
    cannot match pandas for the table (module doc).

    A piece is valid until the next one is asked for (one buffer is reused): write it
    or copy it.
    """
    pieces = row_pieces(frame, chunk_rows)
    return None if pieces is None else (text for text, _ends in pieces)


def csv_bytes(frame: pd.DataFrame) -> bytes | None:
    """The whole CSV text of ``frame`` (see :func:`csv_chunks`), or None."""
    pieces = csv_chunks(frame)
    return None if pieces is None else b"".join([bytes(p) for p in pieces])
