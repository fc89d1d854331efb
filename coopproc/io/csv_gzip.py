"""Gzip-compressed CSV with the bytes of pandas' ``to_csv(..., compression="gzip")``.

Deflate's output depends on how its input is cut into calls. pandas writes a CSV one
row at a time into an ``io.TextIOWrapper`` over a ``gzip.GzipFile``; the text layer
passes its pending bytes on in pieces of about 8 KiB. :func:`write_csv_gzip` gives the
``GzipFile`` the text of :mod:`coopproc.io.csv_fast` in those same pieces, then flushes
and closes it as pandas does, so the compressed file is the same too.
"""

from __future__ import annotations

import gzip
from pathlib import Path
from typing import TYPE_CHECKING

import numba
import numpy as np

from coopproc.io.csv_fast import CHUNK_ROWS, row_pieces

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["TEXT_CHUNK", "write_csv_gzip"]

#: The text layer's buffer of ``io.TextIOWrapper`` (its ``_CHUNK_SIZE``), through which
#: pandas writes a compressed CSV one row at a time.
TEXT_CHUNK = 8192


@numba.njit(cache=True)
def _text_flushes(
    ends: np.ndarray, pending: int, limit: int
) -> tuple[np.ndarray, int]:  # pragma: no cover - jit
    """Where ``io.TextIOWrapper`` would pass its pending bytes on, for rows ending at
    ``ends`` written one by one after ``pending`` bytes; and the bytes then pending.

    CPython's rule: a write that would take the pending bytes past ``limit`` first
    passes them on; pending bytes reaching ``limit`` are passed on at once.
    """
    cuts = np.empty(2 * ends.size, dtype=np.int64)
    k = 0
    previous = 0
    for i in range(ends.size):
        size = ends[i] - previous
        if pending + size > limit and pending > 0:
            cuts[k] = previous
            k += 1
            pending = 0
        pending += size
        if pending >= limit:
            cuts[k] = ends[i]
            k += 1
            pending = 0
        previous = ends[i]
    return cuts[:k], pending


def write_csv_gzip(frame: pd.DataFrame, path: Path, chunk_rows: int = CHUNK_ROWS) -> bool:
    """Write ``frame`` to the gzip file ``path`` with the bytes of pandas'
    ``to_csv(path, compression={"method": "gzip", "mtime": 0}, ...)`` (module doc);
    False (nothing written) for a table the compiled writer does not take.
    """
    pieces = row_pieces(frame, chunk_rows)
    if pieces is None:
        return False
    with gzip.GzipFile(filename=str(path), mode="wb", mtime=0) as handle:
        carry: list[bytes] = []  # pending bytes of the text layer
        pending = 0
        for text, ends in pieces:
            cuts, pending = _text_flushes(ends, pending, TEXT_CHUNK)
            start = 0
            for cut in cuts.tolist():
                if carry:
                    handle.write(b"".join([*carry, text[start:cut]]))
                    carry = []
                else:
                    handle.write(text[start:cut])
                start = cut
            if start < len(text):
                carry.append(bytes(text[start:]))
        if carry:
            handle.write(b"".join(carry))
        handle.flush()  # pandas flushes its text layer, which flushes the GzipFile
    return True
