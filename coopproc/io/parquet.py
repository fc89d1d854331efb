"""Parquet tables (``coopproc run --format parquet``), written with the optional pyarrow.

The numbers are those of the CSV form: every float rounded as ``"%.6f"`` rounds it
(:func:`coopproc.io.csv_fast.round_like_csv`), so a report reads the same values from
either form; integers and text as they are. The file is the same for the same table
(zstd, no timestamps; the pandas and pyarrow versions are in its metadata).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from coopproc.errors import OutputError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["PARQUET_INSTALL", "require_pyarrow", "write_parquet"]

#: What to type to get pyarrow (the ``parquet`` extra).
PARQUET_INSTALL = 'pip install "coopproc[parquet]"'


def _pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as err:
        raise OutputError(
            f"Parquet output needs pyarrow, which is not installed: {PARQUET_INSTALL}"
        ) from err
    return pa, pq


def require_pyarrow() -> None:
    """Raise the one-line OutputError of a missing pyarrow now (before the work)."""
    _pyarrow()


def write_parquet(frame: pd.DataFrame, path: Path, columns: Sequence[str] | None = None) -> Path:
    """Write ``frame`` to ``path`` as Parquet, ``columns`` first (as write_csv orders them)."""
    from coopproc.io.csv_fast import round_like_csv
    from coopproc.io.outdir import columns_first

    pa, pq = _pyarrow()
    frame = columns_first(frame, path, columns)
    rounded = frame.copy(deep=False)
    for j, dtype in enumerate(frame.dtypes):
        if isinstance(dtype, np.dtype) and dtype.kind == "f":
            rounded.isetitem(j, round_like_csv(frame.iloc[:, j].to_numpy()))
    table = pa.Table.from_pandas(rounded, preserve_index=False)
    pq.write_table(table, path, compression="zstd")
    return path
