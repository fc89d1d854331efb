"""An output directory of ``coopproc run`` read back, so reports never recompute.

:class:`RunTables` is the reporters' input: the output tables (DATA.md "Output") and the
run facts of ``run.json``. :func:`load_run` reads it from a directory; the pipeline builds
it from its in-memory tables with the plain constructor.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.model import (
    DI_COLUMNS,
    METRICS_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    POSITION_METRICS_COLUMNS,
    POSITIONS_COLUMNS,
    RANGES_OUT_COLUMNS,
)
from coopproc.report.scores import NLOS_EVENT_SCORE_COLUMNS, NLOS_SCORE_COLUMNS

__all__ = ["RUN_FILES", "RunTables", "load_run"]

#: Columns read as text (ids); every other contract column is numeric.
_TEXT_COLUMNS = ("pair", "platform", "method")

#: (file name, RunTables attribute, required columns, required file).
RUN_FILES: tuple[tuple[str, str, tuple[str, ...], bool], ...] = (
    ("ranges.csv", "ranges", RANGES_OUT_COLUMNS, True),
    ("di.csv", "di", DI_COLUMNS, True),
    ("nlos_events.csv", "nlos_events", NLOS_EVENT_COLUMNS, True),
    ("nlos_estimates.csv", "nlos_estimates", NLOS_ESTIMATE_COLUMNS, False),
    ("positions.csv", "positions", POSITIONS_COLUMNS, True),
    ("metrics.csv", "metrics", METRICS_COLUMNS, True),
    ("position_metrics.csv", "position_metrics", POSITION_METRICS_COLUMNS, True),
    ("nlos_scores.csv", "nlos_scores", NLOS_SCORE_COLUMNS[:2], False),
    ("nlos_event_scores.csv", "nlos_event_scores", NLOS_EVENT_SCORE_COLUMNS[:2], False),
)


@dataclass(frozen=True, eq=False)
class RunTables:
    """The tables of one run plus its ``run.json`` facts (``info``).

    Optional tables are None when the run did not produce them; ``nlos_estimates`` may be
    an empty frame.
    """

    ranges: pd.DataFrame
    di: pd.DataFrame
    nlos_events: pd.DataFrame
    nlos_estimates: pd.DataFrame
    positions: pd.DataFrame
    metrics: pd.DataFrame
    position_metrics: pd.DataFrame
    nlos_scores: pd.DataFrame | None = None
    nlos_event_scores: pd.DataFrame | None = None
    info: Mapping[str, Any] = field(default_factory=dict)

    @property
    def time_origin_s(self) -> float:
        """Earliest time of the ranges and positions tables (0.0 if both are empty)."""
        times = [
            float(np.nanmin(f["time"].to_numpy(dtype=np.float64)))
            for f in (self.ranges, self.positions)
            if len(f) and np.isfinite(f["time"].to_numpy(dtype=np.float64)).any()
        ]
        return min(times) if times else 0.0


def _read_table(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    try:
        header = pd.read_csv(path, nrows=0).columns
        text = {c: str for c in _TEXT_COLUMNS if c in header}
        frame = pd.read_csv(path, dtype=text, keep_default_na=True)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise InputError(path, f"not a readable CSV table ({err})") from err
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
    return frame


def load_run(out_dir: str | Path) -> RunTables:
    """Read the output directory of ``coopproc run``.

    Raises :class:`InputError` naming the file when the directory, a required table or
    ``run.json`` is missing, or a table lacks a contract column or holds a non-number.
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
        path = root / name
        if not path.is_file():
            if required:
                raise InputError(path, "missing; is this an output directory of coopproc run?")
            tables[attr] = pd.DataFrame(columns=list(columns)) if attr == "nlos_estimates" else None
            continue
        tables[attr] = _read_table(path, columns)
    run_json = root / "run.json"
    if not run_json.is_file():
        raise InputError(run_json, "missing; is this an output directory of coopproc run?")
    try:
        info = json.loads(run_json.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(run_json, f"not valid JSON ({err})") from err
    if not isinstance(info, dict):
        raise InputError(run_json, "expected a JSON object")
    return RunTables(info=info, **tables)  # type: ignore[arg-type]
