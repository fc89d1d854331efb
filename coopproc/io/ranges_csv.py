"""ranges.csv (plain or .csv.gz): read and write (DATA.md).

Columns ``time, from, to, range`` required, ``sigma`` optional (NaN where absent or
empty), anything else carried through unchanged. ``A->B`` and ``B->A`` both belong to
pair ``A-B``. Unsorted rows are sorted by time (stable) with a note; exact duplicate
rows are dropped with a note.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.configtools import nearest
from coopproc.errors import InputError
from coopproc.io._common import (
    ID_PATTERN,
    InputProblems,
    Locator,
    missing_column,
    numeric_column,
)
from coopproc.io.csv_forms import CsvForm, read_table
from coopproc.io.outdir import write_csv
from coopproc.model import RANGE_COLUMNS, RangeTable

__all__ = [
    "MAX_RANGE_M",
    "RangesRead",
    "range_table_from_frame",
    "read_ranges_csv",
    "write_ranges_csv",
]

#: Ranges above this are absurd for UWB (typical reach is a few hundred metres).
MAX_RANGE_M = 2000.0
#: A median sigma from this up is not metres either (with ranges in millimetres).
_MAX_SIGMA_M = 10.0

#: Ranges above MAX_RANGE_M on this share of the rows or more (and on 3 rows at least)
#: are a unit, not outliers: the largest range of the shared real sessions, outliers
#: included, is 82.9 m (plaza2), and a receiver's garbage readings (65535) are single rows.
_UNIT_SHARE = 0.1
_UNIT_ROWS = 3

_REQUIRED = ("time", "from", "to", "range")


class RangesRead:
    """A validated range table and what the reader decided (notes)."""

    def __init__(
        self,
        table: RangeTable,
        notes: list[str],
        where: Locator,
        order: np.ndarray | None = None,
    ) -> None:
        self.table = table
        self.notes = notes
        self.where = where
        #: Input row of each table row (tables are sorted; messages name input rows).
        self.order = np.arange(len(table)) if order is None else order

    def error(self, message: str, row: int, count: int = 1) -> InputError:
        """An InputError at table row ``row``, located at its input row."""
        return self.where.error(message, int(self.order[row]), count)


def _ids(
    frame: pd.DataFrame, name: str, where: Locator, problems: list[InputError]
) -> tuple[np.ndarray, np.ndarray]:
    """Column ``name`` as (code of every row, -1 where empty; the distinct ids): a day of
    ranges is millions of rows but a handful of ids, so no per-row Python string."""
    column = frame[name]
    if isinstance(column.dtype, pd.CategoricalDtype):
        codes, ids = _category_ids(column)
    else:
        values = column.astype("string").str.strip()
        codes, uniques = pd.factorize(values, use_na_sentinel=True)
        ids = np.asarray(uniques, dtype=object)
        codes = np.asarray(codes, dtype=np.int64)
    blank = [i for i, u in enumerate(ids) if u == ""]
    if blank:
        codes = np.where(codes == blank[0], -1, codes)
    empty = codes < 0
    if empty.any():
        idx = np.flatnonzero(empty)
        problems.append(
            where.error(f"column '{name}': empty; expected a platform id", int(idx[0]), idx.size)
        )
    # factorize numbers the ids in the order they first appear
    bad_codes = [i for i, u in enumerate(ids) if u != "" and not ID_PATTERN.match(str(u))]
    if bad_codes:
        bad_ids = [ids[c] for c in bad_codes]
        idx = np.flatnonzero(np.isin(codes, bad_codes))
        problems.append(
            where.error(
                f"column '{name}': {str(bad_ids[0])[:40]!r} is not a platform id; expected "
                "letters, digits, '_' and '-'",
                int(idx[0]),
                idx.size,
            )
        )
    return codes, ids


def _category_ids(column: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """What ``pd.factorize`` of the stripped text gives (codes, -1 where missing; the
    distinct ids in the order they first appear), from a categorical column's codes:
    only its few categories are stripped, no string per row is made."""
    stripped = [str(c).strip() for c in column.cat.categories]
    merged, to_merged = np.unique(np.array(stripped, dtype=object), return_inverse=True)
    raw = np.asarray(column.cat.codes.to_numpy(), dtype=np.int64)
    per_row = np.append(to_merged.reshape(-1), -1)[raw]  # code -1 (missing) stays -1
    codes, seen = pd.factorize(per_row)  # ids numbered as they first appear
    first = np.asarray(seen, dtype=np.int64)
    renumber = np.cumsum(first >= 0) - 1  # -1 (missing) is not an id
    out = np.where(first[codes] >= 0, renumber[codes], -1).astype(np.int64)
    return out, np.array([merged[k] for k in first if k >= 0], dtype=object)


def _merged(
    src: tuple[np.ndarray, np.ndarray], dst: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sorted ids, code of every from, of every to) in one id space (-1: empty)."""
    ids = np.array(sorted({str(u) for u in src[1]} | {str(u) for u in dst[1]} - {""}), dtype=object)
    out = []
    for codes, uniques in (src, dst):
        where_in = np.array([np.searchsorted(ids, str(u)) if u != "" else -1 for u in uniques])
        mapped = where_in[np.maximum(codes, 0)] if len(uniques) else np.zeros_like(codes)
        out.append(np.where(codes >= 0, mapped, -1).astype(np.int64))
    return ids, out[0], out[1]


def range_table_from_frame(frame: pd.DataFrame, where: Locator) -> RangesRead:
    """Validate a range table (every kind of problem at once) and build the RangeTable."""
    columns = [str(c) for c in frame.columns]
    problems: list[InputError] = []
    for name in _REQUIRED:
        if name not in columns:
            problems.append(missing_column(name, columns, where))
    if problems:
        raise InputProblems(problems)
    if len(frame) == 0:
        raise where.error("no data rows; expected at least one range")
    notes: list[str] = []
    for name in columns:
        if name not in RANGE_COLUMNS and nearest(name, RANGE_COLUMNS).startswith(" (did"):
            hint = nearest(name, RANGE_COLUMNS)
            notes.append(f"{where.path}: extra column '{name}' carried through as is{hint}")
    time_s = numeric_column(frame, "time", where, problems)
    range_m = numeric_column(frame, "range", where, problems)
    sigma_m = (
        numeric_column(frame, "sigma", where, problems, allow_empty=True)
        if "sigma" in columns
        else np.full(len(frame), np.nan)
    )
    ids, src_code, dst_code = _merged(
        _ids(frame, "from", where, problems), _ids(frame, "to", where, problems)
    )
    neg = range_m < 0
    if neg.any():
        idx = np.flatnonzero(neg)
        problems.append(
            where.error(
                f"range {range_m[idx[0]]} m is negative; expected 0..{MAX_RANGE_M:g} m",
                int(idx[0]),
                idx.size,
            )
        )
    big = np.isfinite(range_m) & (range_m > MAX_RANGE_M)
    finite = range_m[np.isfinite(range_m)]
    if big.any() and float(np.median(finite)) > MAX_RANGE_M:
        # Most ranges absurd: a unit, not outliers (paper 000 ranges are a few to 100 m).
        idx = np.flatnonzero(big)
        sigmas = sigma_m[np.isfinite(sigma_m)]
        mm_sigma = sigmas.size and float(np.median(sigmas)) >= _MAX_SIGMA_M
        both = "ranges and sigmas" if mm_sigma else "ranges"
        problems.append(
            where.error(
                f"ranges look like millimetres (median {float(np.median(finite)):,.0f}; "
                f"{idx.size} of {finite.size} rows above {MAX_RANGE_M:g}); expected metres: "
                f"divide the {both} by 1000, or declare session.toml [columns.units] "
                'range = "mm"',
                int(idx[0]),
            )
        )
    elif np.count_nonzero(big) >= max(_UNIT_ROWS, _UNIT_SHARE * finite.size):
        # Many ranges absurd but the median not: centimetres (20 m reads 2000 cm, so a
        # third of paper 000's ranges pass for metres); outliers are a few rows.
        idx = np.flatnonzero(big)
        sigmas = sigma_m[np.isfinite(sigma_m)]
        cm_sigma = sigmas.size and float(np.median(sigmas)) >= _MAX_SIGMA_M / 10
        both = "ranges and sigmas" if cm_sigma else "ranges"
        problems.append(
            where.error(
                f"ranges look like centimetres (median {float(np.median(finite)):,.0f}; "
                f"{idx.size} of {finite.size} rows above {MAX_RANGE_M:g}); expected metres: "
                f"divide the {both} by 100, or declare session.toml [columns.units] "
                'range = "cm"',
                int(idx[0]),
            )
        )
    elif big.any():
        idx = np.flatnonzero(big)
        problems.append(
            where.error(
                f"range {range_m[idx[0]]} m is absurd for UWB; expected 0..{MAX_RANGE_M:g} m",
                int(idx[0]),
                idx.size,
            )
        )
    bad_sigma = sigma_m <= 0
    if bad_sigma.any():
        idx = np.flatnonzero(bad_sigma)
        problems.append(
            where.error(
                f"sigma {sigma_m[idx[0]]} m; expected a positive 1-sigma or an empty cell",
                int(idx[0]),
                idx.size,
            )
        )
    self_range = (src_code == dst_code) & (src_code >= 0)
    if self_range.any():
        idx = np.flatnonzero(self_range)
        problems.append(
            where.error(
                f"platform {ids[src_code[idx[0]]]} ranges to itself; expected two different "
                "platforms",
                int(idx[0]),
                idx.size,
            )
        )
    if problems:
        raise InputProblems(problems)
    # ids are sorted, so the smaller code is the id that sorts first (pair_name's order)
    lo = np.minimum(src_code, dst_code)
    hi = np.maximum(src_code, dst_code)
    key = lo * len(ids) + hi
    present = np.bincount(key, minlength=len(ids) ** 2) > 0
    keys = np.flatnonzero(present)  # sorted, as np.unique gives them
    inverse = (np.cumsum(present) - 1)[key]
    names = [f"{ids[k // len(ids)]}-{ids[k % len(ids)]}" for k in keys]
    data = {
        "time": time_s,
        "pair": text_column(inverse, names),
        "from": text_column(src_code, ids),
        "to": text_column(dst_code, ids),
        "range": range_m,
        "sigma": sigma_m,
    }
    out = pd.DataFrame(data)
    for name in columns:
        if name not in RANGE_COLUMNS:
            out[name] = frame[name].to_numpy()
    if np.any(np.diff(time_s) < 0):
        order = np.argsort(time_s, kind="stable")
        out = out.iloc[order].reset_index(drop=True)
        notes.append(f"{where.path}: times not in order; rows sorted by time")
    else:
        order = np.arange(len(out))
    dup = _duplicated(out)
    if dup.any():
        out = out[~dup].reset_index(drop=True)
        order = order[~dup]
        notes.append(f"{where.path}: {int(dup.sum())} duplicated row(s) dropped")
    codes = (np.asarray(ids, dtype=object), src_code[order], dst_code[order])
    return RangesRead(RangeTable.with_id_codes(out, where.path, codes), notes, where, order)


def text_column(codes: np.ndarray, names: Sequence[str] | np.ndarray) -> pd.Series:
    """``names[codes]`` as the text column pandas makes of that object array (its
    default ``str`` dtype), built by Arrow from the codes: no Python string per row."""
    dtype = pd.Series(np.array(names[:1], dtype=object)).dtype
    if not (isinstance(dtype, pd.StringDtype) and dtype.storage == "pyarrow"):
        return pd.Series(np.array(names, dtype=object)[codes])  # pragma: no cover
    import pyarrow as pa

    table = pa.array(list(names), type=pa.large_string())
    text = pa.DictionaryArray.from_arrays(pa.array(codes, type=pa.int32()), table)
    return pd.Series(pd.array(text.dictionary_decode(), dtype=dtype))


def _duplicated(frame: pd.DataFrame) -> np.ndarray:
    """``frame.duplicated(keep="first")`` of a table sorted by time: exact duplicates
    share their time, so only rows whose time is not unique are compared."""
    time_s = frame["time"].to_numpy()
    same = np.diff(time_s) == 0
    candidate = np.zeros(len(frame), dtype=bool)
    candidate[1:] |= same
    candidate[:-1] |= same
    dup = np.zeros(len(frame), dtype=bool)
    if candidate.any():
        rows = np.flatnonzero(candidate)
        dup[rows] = frame.iloc[rows].duplicated(keep="first").to_numpy()
    return dup


def read_ranges_csv(path: str | Path, form: CsvForm | None = None) -> RangesRead:
    """Read ranges.csv (or .csv.gz); raises InputError.

    ``form``: encoding, column names and units other than the defaults (session.toml).
    """
    table = read_table(
        Path(path),
        RANGE_COLUMNS,
        "time,from,to,range (then optional sigma and extra columns)",
        form,
        required=_REQUIRED,
        coded_columns=("from", "to"),
    )
    out = range_table_from_frame(table.frame, table.where)
    out.notes[:0] = table.notes
    return out


def write_ranges_csv(table: RangeTable, path: str | Path) -> Path:
    """Write a range table as ranges.csv (``pair`` is derived on reading, so not written)."""
    return write_csv(table.frame.drop(columns=["pair"]), Path(path))
