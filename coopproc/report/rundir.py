"""An output directory of ``coopproc run`` read back, so reports never recompute.

:class:`~coopproc.report.run_tables.RunTables` is the reporters' input: the output tables
(DATA.md "Output") and the run facts of ``run.json``. :func:`load_run` reads it from a
directory; the pipeline builds it from its in-memory tables with the plain constructor.

The per-epoch tables may be Parquet files instead (``coopproc run --format parquet``:
``positions.parquet``, ...; :data:`PARQUET_TABLES`); either form is read the same way.

The methods of a run are not fixed (:mod:`coopproc.report.methods`): ``ranges.csv`` has
``time, pair, observed``, then one column per range method of the chain, then
``reference, nlos_flag, nlos_estimate`` (:func:`ranges_columns`) and, from runs since the
gross-outlier rejection, ``outlier``; only those six are required, plus every range method
that run.json ``"methods"`` lists.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.model import (
    DI_COLUMNS,
    DR_STATES_COLUMNS,
    METRICS_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    POSITION_METRICS_COLUMNS,
    POSITIONS_COLUMNS,
    STATES_COLUMNS,
)
from coopproc.names import LSQ_QUALITY_COLUMNS, RANGE_WEIGHTS_COLUMNS
from coopproc.report.methods import METHOD_KEYS, listed_methods, range_methods_of
from coopproc.report.outage import OUTAGE_COLUMNS
from coopproc.report.run_tables import RunTables
from coopproc.report.scores import NLOS_EVENT_SCORE_COLUMNS, NLOS_SCORE_COLUMNS

__all__ = [
    "PARQUET_TABLES",
    "RANGES_LEADING_COLUMNS",
    "RANGES_REQUIRED_COLUMNS",
    "RANGES_TRAILING_COLUMNS",
    "RUN_EXTENSION_FILES",
    "RUN_FILES",
    "find_table",
    "load_run",
    "ranges_columns",
    "read_table_file",
    "table_file_name",
]

#: Columns read as text (ids; ``alignment`` of evaluation.csv / rpe.csv; ``kind``,
#: ``group``, ``baseline`` of comparisons.csv; ``status`` of lsq_quality.csv); every other
#: contract column is numeric.
_TEXT_COLUMNS = ("pair", "platform", "method", "alignment", "kind", "group", "baseline", "status")

#: ``ranges.csv`` columns before the range methods (``observed`` is always one) and after.
RANGES_LEADING_COLUMNS: tuple[str, ...] = ("time", "pair", "observed")
RANGES_TRAILING_COLUMNS: tuple[str, ...] = ("reference", "nlos_flag", "nlos_estimate")
#: The columns every ``ranges.csv`` has, whatever its methods.
RANGES_REQUIRED_COLUMNS = (*RANGES_LEADING_COLUMNS, *RANGES_TRAILING_COLUMNS)


def ranges_columns(methods: Sequence[str]) -> tuple[str, ...]:
    """Columns of ``ranges.csv`` for the range ``methods`` in chain order (``observed``
    included or not): ``time, pair, observed, <methods>, reference, nlos_flag, nlos_estimate``."""
    middle = [m for m in dict.fromkeys(methods) if m not in RANGES_REQUIRED_COLUMNS]
    return (*RANGES_LEADING_COLUMNS, *middle, *RANGES_TRAILING_COLUMNS)


#: (file name, RunTables attribute, leading columns, required file). The leading columns
#: are written first, in this order, and required on reading. For ``ranges.csv`` they are
#: :data:`RANGES_LEADING_COLUMNS`: the method columns follow in the table's own order and
#: the reader also requires :data:`RANGES_TRAILING_COLUMNS` (order the table with
#: :func:`ranges_columns`).
RUN_FILES: tuple[tuple[str, str, tuple[str, ...], bool], ...] = (
    ("ranges.csv", "ranges", RANGES_LEADING_COLUMNS, True),
    ("di.csv", "di", DI_COLUMNS, True),
    ("nlos_events.csv", "nlos_events", NLOS_EVENT_COLUMNS, True),
    ("nlos_estimates.csv", "nlos_estimates", NLOS_ESTIMATE_COLUMNS, False),
    ("positions.csv", "positions", POSITIONS_COLUMNS, True),
    ("metrics.csv", "metrics", METRICS_COLUMNS, True),
    ("position_metrics.csv", "position_metrics", POSITION_METRICS_COLUMNS, True),
    ("nlos_scores.csv", "nlos_scores", NLOS_SCORE_COLUMNS[:2], False),
    ("nlos_event_scores.csv", "nlos_event_scores", NLOS_EVENT_SCORE_COLUMNS[:2], False),
)
#: Tables a run writes only when it has them (same layout as RUN_FILES; never required):
#: ``injected_scores.csv`` for a session made by ``coopproc inject`` (report/injected.py);
#: ``evaluation.csv`` and ``rpe.csv`` (report/evaluation.py, report/rpe.py), which older
#: run directories lack; ``states.csv`` for a run with INS methods (coopproc/run/ins.py);
#: ``outages.csv`` for a run with ``[run] outages`` (coopproc/run/outages.py);
#: ``comparisons.csv``, the paired comparisons of methods (report/comparisons.py).
RUN_EXTENSION_FILES: tuple[tuple[str, str, tuple[str, ...], bool], ...] = (
    ("injected_scores.csv", "injected_scores", ("pair", "method"), False),
    ("evaluation.csv", "evaluation", ("platform", "method", "alignment"), False),
    ("rpe.csv", "rpe", ("platform", "method", "alignment", "segment_m"), False),
    ("states.csv", "states", STATES_COLUMNS, False),
    ("dr_states.csv", "dr_states", DR_STATES_COLUMNS, False),
    ("range_weights.csv", "range_weights", RANGE_WEIGHTS_COLUMNS, False),
    ("lsq_quality.csv", "lsq_quality", LSQ_QUALITY_COLUMNS, False),
    ("outages.csv", "outages", OUTAGE_COLUMNS, False),
    ("comparisons.csv", "comparisons", ("kind", "group", "method", "baseline"), False),
)


#: Columns each table must have, by attribute (the leading columns unless listed here).
_REQUIRED = {"ranges": RANGES_REQUIRED_COLUMNS}

#: The per-epoch tables, which ``coopproc run --format parquet`` (``[run] format``)
#: writes as ``<name>.parquet``; the summary tables are always CSV.
PARQUET_TABLES: tuple[str, ...] = ("ranges.csv", "di.csv", "nlos_estimates.csv", "positions.csv")


def table_file_name(name: str, table_format: str = "csv") -> str:
    """The file of table ``name`` ("positions.csv") in a run written in ``table_format``."""
    if table_format == "parquet" and name in PARQUET_TABLES:
        return name.removesuffix(".csv") + ".parquet"
    return name


def find_table(root: Path, name: str) -> Path | None:
    """The file of table ``name`` ("positions.csv") in the run directory ``root``: the CSV,
    else its Parquet form; None when there is neither."""
    for form in ("csv", "parquet"):
        path = root / table_file_name(name, form)
        if path.is_file():
            return path
    return None


def read_table_file(path: Path, text: Sequence[str] = _TEXT_COLUMNS) -> pd.DataFrame:
    """A run table as written, CSV or Parquet (by its suffix), with the ``text`` columns
    read as text; the errors of the readers are left to the caller (OSError,
    ValueError, pandas' ParserError; ImportError: a Parquet table without pyarrow)."""
    if path.suffix == ".parquet":
        frame = pd.read_parquet(path)
        for col in text:
            if col in frame.columns and not pd.api.types.is_string_dtype(frame[col]):
                frame[col] = frame[col].astype(str)
        return frame
    header = pd.read_csv(path, nrows=0).columns
    return pd.read_csv(path, dtype={c: str for c in text if c in header}, keep_default_na=True)


def _read_table(path: Path, columns: Sequence[str]) -> pd.DataFrame:
    try:
        frame = read_table_file(path)
    except ImportError as err:
        raise InputError(
            path, 'a Parquet table; reading it needs pyarrow: pip install "coopproc[parquet]"'
        ) from err
    except (OSError, ValueError, pd.errors.ParserError) as err:
        form = "Parquet" if path.suffix == ".parquet" else "CSV"
        raise InputError(path, f"not a readable {form} table ({err})") from err
    if not len(frame):  # header only: every column but the ids is numeric (e.g. a method)
        for col in frame.columns:
            if col not in _TEXT_COLUMNS:
                frame[col] = frame[col].astype(np.float64)
    _check_columns(path, frame, columns)
    return frame


def _check_columns(path: Path, frame: pd.DataFrame, columns: Sequence[str]) -> None:
    """One-line InputError for a missing column or a non-number; converts empty columns."""
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise InputError(path, f"missing columns {missing}; expected {list(columns)}", line=1)
    for col in columns:
        if col in _TEXT_COLUMNS:
            continue
        if not pd.api.types.is_numeric_dtype(frame[col]):
            bad = pd.to_numeric(frame[col], errors="coerce").isna() & frame[col].notna()
            if not bad.any():  # e.g. an empty table: nothing to read as text
                frame[col] = pd.to_numeric(frame[col])
                continue
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(
                path,
                f"column {col!r}: expected a number, found {frame[col].iloc[row]!r}",
                line=row + 2,
            )


def _read_info(run_json: Path) -> dict[str, Any]:
    if not run_json.is_file():
        raise InputError(run_json, "missing; is this an output directory of coopproc run?")
    try:
        info = json.loads(run_json.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(run_json, f"not valid JSON ({err})") from err
    if not isinstance(info, dict):
        raise InputError(run_json, "expected a JSON object")
    methods = info.get("methods")
    if methods is not None and (
        not isinstance(methods, dict)
        or any(k in methods and listed_methods(info, k) is None for k in METHOD_KEYS)
    ):
        raise InputError(
            run_json,
            'key "methods": expected an object of method-name lists, e.g. '
            '{"ranges": ["observed", "di"], "positions": ["observed", "di"]}',
        )
    return info


def load_run(out_dir: str | Path) -> RunTables:
    """Read the output directory of ``coopproc run``.

    Raises :class:`InputError` naming the file when the directory, a required table or
    ``run.json`` is missing, or a table lacks a contract column (for ``ranges.csv`` also a
    range method that run.json lists) or holds a non-number.
    """
    root = Path(out_dir)
    if not root.is_dir():
        raise InputError(root, "not an output directory of coopproc run")
    if not (root / "run.json").is_file() and any(root.glob("nav_*")):
        raise InputError(
            root,
            "this is a session (input) directory; report reads what `coopproc run "
            f"{root} -o OUT` writes: run it first, then `coopproc report OUT`",
        )
    tables: dict[str, pd.DataFrame | None] = {}
    for name, attr, columns, required in RUN_FILES:
        path = find_table(root, name)
        if path is None:
            if required:
                raise InputError(
                    root / name, "missing; is this an output directory of coopproc run?"
                )
            tables[attr] = pd.DataFrame(columns=list(columns)) if attr == "nlos_estimates" else None
            continue
        tables[attr] = _read_table(path, _REQUIRED.get(attr, columns))
    for name, attr, columns, _required in RUN_EXTENSION_FILES:
        path = root / name
        tables[attr] = _read_table(path, columns) if path.is_file() else None
    info = _read_info(root / "run.json")
    ranges = tables["ranges"]
    if ranges is not None:  # the range methods are columns of numbers too
        listed = listed_methods(info, "ranges")
        methods = range_methods_of(ranges) if listed is None else listed
        _check_columns(
            find_table(root, "ranges.csv") or root / "ranges.csv", ranges, ranges_columns(methods)
        )
    return RunTables(info=info, **tables)  # type: ignore[arg-type]
