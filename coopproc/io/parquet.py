"""Parquet tables (``coopproc run --format parquet``), written with the optional pyarrow.

The numbers are those of the CSV form: every float rounded as ``"%.6f"`` rounds it
(:func:`coopproc.io.csv_fast.round_like_csv`), so a report reads the same values from
either form; integers and text as they are. The file is the same for the same table
(zstd, no timestamps; the pandas and pyarrow versions are in its metadata).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import OutputError

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


#: Rows per Parquet row group: the table is rounded and converted a group at a time, so
#: a day's positions table is never held twice (rounded copy, Arrow table).
ROW_GROUP_ROWS = 1 << 20


def write_parquet(
    frame: pd.DataFrame,
    path: Path,
    columns: Sequence[str] | None = None,
    row_group_rows: int = ROW_GROUP_ROWS,
) -> Path:
    """Write ``frame`` to ``path`` as Parquet, ``columns`` first (as write_csv orders them).

    Categorical text columns are written as plain text (the file reads back as the CSV
    does); the rows go in groups of ``row_group_rows``, each rounded and converted on its
    own.
    """
    from coopproc.io.csv_fast import round_like_csv
    from coopproc.io.outdir import columns_first

    pa, pq = _pyarrow()
    frame = columns_first(frame, path, columns)
    writer = None
    try:
        for start in range(0, max(len(frame), 1), row_group_rows):
            part = frame.iloc[start : start + row_group_rows]
            rounded = part.copy(deep=False)
            for j, dtype in enumerate(part.dtypes):
                if isinstance(dtype, np.dtype) and dtype.kind == "f":
                    rounded.isetitem(j, round_like_csv(part.iloc[:, j].to_numpy()))
                elif isinstance(dtype, pd.CategoricalDtype):
                    rounded.isetitem(j, part.iloc[:, j].astype(dtype.categories.dtype).array)
            schema = None if writer is None else writer.schema  # every group as the first
            table = pa.Table.from_pandas(rounded, schema=schema, preserve_index=False)
            if writer is None:
                writer = pq.ParquetWriter(path, table.schema, compression="zstd")
            writer.write_table(table)
    finally:
        if writer is not None:
            writer.close()
    return path
