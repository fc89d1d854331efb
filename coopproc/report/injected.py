"""The methods scored against what ``coopproc inject`` injected (paper 000 Table 1 in form).

For each injected NLOS event (the ``nlos`` rows of a session's ``injected.csv``, one
event id each) and each NLOS method of the run, ``injected_scores.csv`` holds:

- ``pair``, ``method``, ``event``: the event's pair, the scored method, the event id;
- ``start``, ``end``: the window asked for; ``epochs``: the ranges the errors went into;
- ``injected_mean``: the mean of N(mean, sd^2) the errors were drawn from (Table 1's
  "reference value"); ``realized_mean``: the mean of the errors actually added;
- ``estimated``: the ``estimate`` of the method's event in ``nlos_events.csv`` that
  overlaps the injected ranges most (the longest overlap in time; the earliest of equals);
- ``error``: ``estimated - injected_mean`` (signed; Table 1's "error value" is its
  magnitude); ``error_pct``: ``100 abs(error) / injected_mean`` ("percentage error");
- ``detected``: 1 when an event of the method overlaps the injected ranges (first to
  last), else 0; ``events``: how many do (more than 1: the detection broke up);
- ``delay``: the start of the first overlapping event minus the first injected range's
  time, s (negative: an event was already running).

``estimated``, ``error``, ``error_pct`` and ``delay`` are empty when not detected.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from coopproc.report.methods import nlos_methods
from coopproc.report.tables import METRIC_SPECS, MetricSpec, Row, Table

if TYPE_CHECKING:
    from coopproc.report.run_tables import RunTables

__all__ = [
    "INJECTED_METRICS",
    "INJECTED_SCORE_COLUMNS",
    "injected_scores",
    "injected_table",
    "injected_tables",
]

INJECTED_SCORE_COLUMNS: tuple[str, ...] = (
    "pair",
    "method",
    "event",
    "start",
    "end",
    "epochs",
    "injected_mean",
    "realized_mean",
    "estimated",
    "error",
    "error_pct",
    "detected",
    "events",
    "delay",
)
#: How the table shows each column (label, unit, decimals, which value is best),
#: registered with the other statistics' in :data:`coopproc.report.tables.METRIC_SPECS`.
_SPECS: dict[str, MetricSpec] = {
    "injected_mean": MetricSpec("Injected", "m", 4, None),
    "estimated": MetricSpec("Estimated", "m", 4, None),
    "error": MetricSpec("Error", "m", 4, "absmin", signed=True),
    "error_pct": MetricSpec("Error", "%", 2, "min"),
    "detected": MetricSpec("Detected", "", 0, "max"),
    "delay": MetricSpec("Delay", "s", 2, "absmin", signed=True),
}
for _name, _spec in _SPECS.items():
    METRIC_SPECS.setdefault(_name, _spec)
#: The columns of the table, in order.
INJECTED_METRICS: tuple[str, ...] = tuple(_SPECS)


def _score(onset: float, last: float, mean: float, events: pd.DataFrame) -> dict[str, float | int]:
    start = events["start"].to_numpy(dtype=np.float64)
    end = events["end"].to_numpy(dtype=np.float64)
    hit = (start <= last) & (end >= onset)
    if not hit.any():
        nan = float("nan")
        return {"estimated": nan, "error": nan, "error_pct": nan, "detected": 0, "events": 0}
    overlap = np.minimum(end, last) - np.maximum(start, onset)
    # the longest overlap, the earliest start among equals
    best = min(np.flatnonzero(hit), key=lambda i: (-overlap[i], start[i]))
    estimate = float(events["estimate"].to_numpy(dtype=np.float64)[best])
    error = estimate - mean
    return {
        "estimated": estimate,
        "error": error,
        "error_pct": 100.0 * abs(error) / mean if mean else float("nan"),
        "detected": 1,
        "events": int(np.count_nonzero(hit)),
        "delay": float(start[hit].min()) - onset,
    }


def injected_scores(
    injected: pd.DataFrame, nlos_events: pd.DataFrame, methods: Sequence[str]
) -> pd.DataFrame:
    """One row per injected NLOS event and method (:data:`INJECTED_SCORE_COLUMNS`).

    ``injected``: the rows of ``injected.csv`` (:func:`coopproc.io.injected.read_injected`);
    ``nlos_events``: the run's ``nlos_events.csv``; ``methods``: the NLOS methods, in order.
    """
    rows = []
    nlos = injected[injected["kind"] == "nlos"]
    for event, group in nlos.groupby("event", sort=False):
        pair = str(group["pair"].iloc[0])
        times = group["time"].to_numpy(dtype=np.float64)
        mean = float(group["mean"].iloc[0])
        for method in methods:
            mine = nlos_events[(nlos_events["pair"] == pair) & (nlos_events["method"] == method)]
            rows.append(
                {
                    "pair": pair,
                    "method": method,
                    "event": str(event),
                    "start": float(group["start"].iloc[0]),
                    "end": float(group["end"].iloc[0]),
                    "epochs": len(group),
                    "injected_mean": mean,
                    "realized_mean": float(group["error"].mean()),
                    "delay": float("nan"),
                    **_score(float(times.min()), float(times.max()), mean, mine),
                }
            )
    out = pd.DataFrame(rows, columns=list(INJECTED_SCORE_COLUMNS))
    for col in ("epochs", "detected", "events"):
        out[col] = out[col].astype(np.int64)
    return out


def _best(name: str, values: list[float]) -> set[int]:
    better = METRIC_SPECS[name].better
    arr = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(arr)
    if better is None or np.count_nonzero(ok) < 2:
        return set()
    score = {"min": arr, "max": -arr, "absmin": np.abs(arr), "one": np.abs(arr - 1.0)}[better]
    winners = ok & np.isclose(score, np.min(score[ok]), rtol=0, atol=1e-12)
    return set() if np.array_equal(winners, ok) else {int(i) for i in np.flatnonzero(winners)}


def injected_table(
    scores: pd.DataFrame,
    metrics: Sequence[str] = INJECTED_METRICS,
    order: Sequence[str] = (),
) -> Table:
    """The scores as a table: a group per event (``nlos1 A-B``), a row per method in
    ``order`` (then the others), the best value of each column within the event marked."""
    rows: list[Row] = []
    rank = {m: i for i, m in enumerate(order)}
    for event, block in scores.groupby("event", sort=False):
        records = sorted(
            block.to_dict("records"), key=lambda r: rank.get(str(r["method"]), len(rank))
        )
        best = {m: _best(m, [float(r[m]) for r in records]) for m in metrics}
        for i, rec in enumerate(records):
            rows.append(
                Row(
                    group=f"{event} {rec['pair']}",
                    method=str(rec["method"]),
                    values={m: float(rec[m]) for m in metrics},
                    change={m: None for m in metrics},
                    best=frozenset(m for m in metrics if i in best[m]),
                )
            )
    return Table(
        "injected",
        "Injected NLOS: estimates against the injected mean (paper 000 Table 1)",
        "Event",
        tuple(metrics),
        tuple(rows),
        False,
    )


def injected_tables(
    run: RunTables,
    *,
    metrics: Sequence[str] | None = None,
    pairs: Sequence[str] | None = None,
) -> list[Table]:
    """The injected-NLOS table of a run that has ``injected_scores.csv`` (else none),
    restricted to ``pairs`` and to the ``metrics`` it has (none of them: no table)."""
    scores = getattr(run, "injected_scores", None)
    if scores is None or not len(scores):
        return []
    if pairs is not None:
        scores = scores[scores["pair"].isin(list(pairs))]
    columns = INJECTED_METRICS if metrics is None else [m for m in metrics if m in _SPECS]
    if not columns or not len(scores):
        return []
    return [injected_table(scores, columns, nlos_methods(run))]
