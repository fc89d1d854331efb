"""The report's tables as data: :class:`Table` of :class:`Row` (one method of one pair or
platform), the change of a value against Observed (:mod:`coopproc.report.change`) and the
best value of a column (decided on the printed values, so ties print alike and are all
marked). Built by :mod:`coopproc.report.tables`, rendered by :mod:`coopproc.report.formats`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from coopproc.report.change import Change, change_of
from coopproc.report.table_specs import METRIC_SPECS, MetricSpec

__all__ = ["Row", "Table", "best_rows", "change_against"]


@dataclass(frozen=True)
class Row:
    """One method of one group: values, change vs observed (None: not shown), best cells;
    the confidence interval of each statistic that has one, and the statistics whose
    change against Observed is significant (the paired comparison's p below the level)."""

    group: str
    method: str
    values: dict[str, float]
    change: dict[str, Change | None]
    best: frozenset[str]
    interval: dict[str, tuple[float, float]] = field(default_factory=dict)
    significant: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Table:
    """A titled table; ``group_label`` names the first column (Pair / Platform)."""

    key: str
    title: str
    group_label: str
    metrics: tuple[str, ...]
    rows: tuple[Row, ...]
    #: True when rows carry a change against observed.
    has_change: bool
    #: Confidence level of the rows' intervals (None: none shown).
    level: float | None = None
    #: Level of the significance marks (None: none computed).
    significance: float | None = None

    @property
    def marks(self) -> frozenset[str]:
        """What the rows show: ``best``, ``change``, ``interval``, ``significant`` (a
        table's notes explain only these)."""
        shown = {
            "best": any(r.best for r in self.rows),
            "change": any(c is not None for r in self.rows for c in r.change.values()),
            "interval": any(r.interval for r in self.rows),
            "significant": any(r.significant for r in self.rows),
        }
        return frozenset(k for k, v in shown.items() if v)

    def header(self, name: str) -> str:
        """Column header with the unit, e.g. ``Max (m)``."""
        spec = METRIC_SPECS.get(name, MetricSpec(name))
        return f"{spec.label} ({spec.unit})" if spec.unit else spec.label


def change_against(
    name: str, value: float, observed: float, signed: Sequence[str]
) -> Change | None:
    """The change of ``value`` against Observed's for statistic ``name`` (None: not
    compared); ``signed``: names compared as signed statistics."""
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    if name == "n" or spec.better is None:
        return None
    return change_of(
        value,
        observed,
        unit=spec.unit,
        decimals=spec.decimals,
        signed=spec.signed or name in signed,
    )


def best_rows(name: str, values: list[float]) -> set[int]:
    """Rows holding the best value of a column, decided on the printed values: values
    that print alike are tied and all marked (issue 32: "0.0247" three times, one
    starred); all tied: none."""
    spec = METRIC_SPECS.get(name, MetricSpec(name))
    better = spec.better
    d = spec.decimals
    arr = np.array([float(f"{v:.{d}f}") if math.isfinite(v) else v for v in values])
    ok = np.isfinite(arr)
    if better is None or np.count_nonzero(ok) < 2:
        return set()
    score = {"min": arr, "max": -arr, "absmin": np.abs(arr), "one": np.abs(arr - 1.0)}[better]
    score = np.round(score, d + 1)  # |x - 1| of printed values: no binary residue
    best = np.min(score[ok])
    winners = ok & (score == best)
    if np.array_equal(winners, ok):
        return set()  # all equal: nothing is best
    return {int(i) for i in np.flatnonzero(winners)}
