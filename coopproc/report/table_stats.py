"""What Table 2 and Table 3 show beside the point figures: the confidence intervals of
their statistics and which changes against Observed are significant.

The intervals are ``metrics.csv`` / ``position_metrics.csv``'s ``<stat>_lo`` /
``<stat>_hi`` columns when they hold the asked level (``coopproc run`` writes 95 %);
another level (``report --ci 0.9``) or a run directory written before the columns existed
gets them recomputed from ``ranges.csv`` / ``positions.csv`` (the same seeded bootstrap:
:mod:`coopproc.report.intervals`, so the 95 % figures are the CSV's to the digit). The
significant changes come from ``comparisons.csv`` (recomputed when the run lacks it):
a method's RMSE or mean change against Observed is marked when the paired comparison's
p-value is below ``--significance`` (default 0.05).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import pandas as pd

from coopproc.names import pair_name
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.comparisons import comparisons
from coopproc.report.intervals import (
    DISTANCE_INTERVAL_STATS,
    POSITION_INTERVAL_STATS,
    interval_columns,
)
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.report.run_tables import RunTables

__all__ = [
    "COMPARED_STATS",
    "DEFAULT_SIGNIFICANCE",
    "Stars",
    "TableFrames",
    "swapped_pair",
    "table_frames",
]

#: Level of the significance marks (``--significance``).
DEFAULT_SIGNIFICANCE = 0.05
#: Statistics with a paired comparison (comparisons.csv ``<stat>_p``).
COMPARED_STATS: tuple[str, ...] = ("rmse", "mean")


def swapped_pair(name: str, known: Sequence[str]) -> str:
    """``name``, or the pair ``A-B`` when ``name`` is ``B-A`` and only ``A-B`` is known."""
    if name in known or "-" not in name:
        return name
    a, _, b = name.partition("-")
    swapped = pair_name(a, b)
    return swapped if swapped in known else name


@dataclass(frozen=True)
class Stars:
    """The significant changes against Observed of one table: ``marks[(group, method)]``
    the statistics whose paired comparison has ``p < alpha``."""

    alpha: float
    marks: Mapping[tuple[str, str], frozenset[str]]

    def marked(self, group: str, method: str) -> frozenset[str]:
        """The marked statistics of one row."""
        return self.marks.get((group, method), frozenset())


@dataclass(frozen=True)
class TableFrames:
    """Table 2's and Table 3's rows with their interval columns, and their marks."""

    metrics: pd.DataFrame
    position_metrics: pd.DataFrame
    distance_stars: Stars | None
    position_stars: Stars | None


def _with_intervals(
    table: pd.DataFrame, fresh: pd.DataFrame, key: str, stats: Sequence[str]
) -> pd.DataFrame:
    """``table`` with its interval columns replaced by ``fresh``'s (matched on key, method)."""
    columns = list(interval_columns(stats))
    kept = table.drop(columns=[c for c in columns if c in table.columns])
    return kept.merge(fresh[[key, "method", *columns]], on=[key, "method"], how="left")


def _has(table: pd.DataFrame, stats: Sequence[str]) -> bool:
    return all(c in table.columns for c in interval_columns(stats))


def _stars(frame: pd.DataFrame, kind: str, alpha: float) -> Stars:
    marks: dict[tuple[str, str], frozenset[str]] = {}
    rows = frame[(frame["kind"] == kind) & (frame["baseline"] == "observed")]
    for rec in rows.to_dict("records"):
        marked = frozenset(s for s in COMPARED_STATS if float(rec[f"{s}_p"]) < alpha)
        marks[(str(rec["group"]), str(rec["method"]))] = marked
    return Stars(alpha, marks)


def table_frames(
    run: RunTables,
    level: float | None,
    alpha: float | None,
    orders: Mapping[str, Sequence[str]],
) -> TableFrames:
    """The rows of Table 2 and Table 3 with intervals at ``level`` (None: the tables as
    read) and the changes significant at ``alpha`` (None: no marks); ``orders``: the run's
    methods (:func:`coopproc.report.tables.run_method_orders`)."""
    metrics, positions = run.metrics, run.position_metrics
    has_ranges = {"time", "pair", "reference"} <= set(run.ranges.columns)
    has_positions = {"time", "platform", "method", "error_h"} <= set(run.positions.columns)
    if level is not None:
        if has_ranges and (level != DEFAULT_LEVEL or not _has(metrics, DISTANCE_INTERVAL_STATS)):
            fresh = distance_metrics(run.ranges, orders["table2"], level=level)
            metrics = _with_intervals(metrics, fresh, "pair", DISTANCE_INTERVAL_STATS)
        if has_positions and (
            level != DEFAULT_LEVEL or not _has(positions, POSITION_INTERVAL_STATS)
        ):
            fresh = position_metrics(run.positions, orders["table3"][1:], level=level)
            positions = _with_intervals(positions, fresh, "platform", POSITION_INTERVAL_STATS)
    if alpha is None:
        return TableFrames(metrics, positions, None, None)
    compared = run.comparisons
    if compared is None:
        compared = comparisons(
            run.ranges if has_ranges else run.ranges.iloc[:0],
            run.positions if has_positions else run.positions.iloc[:0],
            orders["table2"],
            orders["table3"],
            DEFAULT_LEVEL,
        )
    return TableFrames(
        metrics, positions, _stars(compared, "pair", alpha), _stars(compared, "platform", alpha)
    )
