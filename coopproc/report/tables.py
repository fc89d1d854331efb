"""The paper's tables as data: Table 2 (pair x method), Table 3 (platform x method), NLOS scores.

A :class:`Table` holds the numbers, the change against ``observed`` (relative in % for
magnitudes, absolute for signed statistics, dB and near-zero references: the rule of
:mod:`coopproc.report.change`) and which cell is the best of its column within each group
(pair or platform); :mod:`coopproc.report.formats` renders it as terminal text, CSV,
Markdown, LaTeX or HTML. Rows are the methods of the metrics tables, in the run's method
order when one is given (:mod:`coopproc.report.methods`); a method without a display name
in :data:`METHOD_LABELS` is shown by its own name (:func:`method_label`).

The ``mean`` of Table 2 (signed distance errors) is a signed statistic, so its change is
absolute (paper 000's text compares magnitudes in %, "the mean error ... fell by 17.07%",
which for a mean near zero prints thousands of %); Table 3's ``mean`` (of horizontal
errors) is a magnitude.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError
from coopproc.model import METRICS_COLUMNS
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.change import Change
from coopproc.report.methods import method_order, nlos_methods, position_methods, range_methods
from coopproc.report.metrics import POSITION_METRICS_EXTRA_COLUMNS
from coopproc.report.outlier_scores import FUSION_PREFIX
from coopproc.report.run_tables import RunTables
from coopproc.report.table_rows import Row, Table, best_rows, change_against
from coopproc.report.table_specs import (
    METHOD_LABELS,
    METRIC_SPECS,
    MetricSpec,
    method_label,
    number_text,
)
from coopproc.report.table_stats import DEFAULT_SIGNIFICANCE, Stars, swapped_pair, table_frames

__all__ = [
    "METHOD_LABELS",
    "METRIC_SPECS",
    "POSITION_ALL",
    "MetricSpec",
    "Row",
    "Table",
    "axis_table",
    "build_tables",
    "distance_table",
    "fusion_outlier_table",
    "method_label",
    "nlos_table",
    "number_text",
    "position_table",
    "run_method_orders",
]

_DISTANCE_DEFAULT = tuple(c for c in METRICS_COLUMNS if c not in ("pair", "method"))
_POSITION_DEFAULT = ("max", "mean", "rmse", "cep50", "cep95", "n")
#: Every column of Table 3 (the HTML page shows them all).
POSITION_ALL = ("max", "mean", "rmse", *POSITION_METRICS_EXTRA_COLUMNS, "n")
#: Every column of Table 3 per axis (coopproc.report.axis_metrics).
_AXIS_ALL = (
    *(f"{s}_{a}" for s in ("rms", "max") for a in ("east", "north", "up")),
    *(f"rms_{c}" for c in ("vel_east", "vel_north", "vel_up", "roll", "pitch", "yaw")),
)
_NLOS_DEFAULT = ("precision", "recall", "f1", "events", "estimate_mae")
_OUTLIER_DEFAULT = ("precision", "recall", "f1", "down_weighted", "rejected")


def _build(
    frame: pd.DataFrame,
    group_col: str,
    metrics: Sequence[str],
    *,
    key: str,
    title: str,
    group_label: str,
    with_change: bool,
    order: Sequence[str] = (),
    signed: Sequence[str] = (),
    level: float | None = None,
    stars: Stars | None = None,
) -> Table:
    """``level``: show the ``<m>_lo`` / ``<m>_hi`` columns of ``frame`` as intervals;
    ``stars``: the significant changes against Observed."""
    rows: list[Row] = []
    for group, block in frame.groupby(group_col, sort=True):
        records = block.to_dict("records")
        ranked = method_order([str(r["method"]) for r in records], order)
        records.sort(key=lambda r: ranked.index(str(r["method"])))
        observed = next((r for r in records if r["method"] == "observed"), None)
        best = {m: best_rows(m, [float(r[m]) for r in records]) for m in metrics}
        for i, rec in enumerate(records):
            values = {m: float(rec[m]) for m in metrics}
            change: dict[str, Change | None] = {m: None for m in metrics}
            if with_change and observed is not None and rec["method"] != "observed":
                base = {m: float(observed[m]) for m in metrics}
                change = {m: change_against(m, values[m], base[m], signed) for m in metrics}
            bounds = {}
            if level is not None:
                bounds = {
                    m: (float(rec[f"{m}_lo"]), float(rec[f"{m}_hi"]))
                    for m in metrics
                    if math.isfinite(float(rec.get(f"{m}_lo", math.nan)))
                }
            marked = stars.marked(str(group), str(rec["method"])) if stars else frozenset()
            rows.append(
                Row(
                    group=str(group),
                    method=str(rec["method"]),
                    values=values,
                    change=change,
                    best=frozenset(m for m in metrics if i in best[m]),
                    interval=bounds,
                    significant=frozenset(m for m in marked if change.get(m) is not None),
                )
            )
    return Table(
        key,
        title,
        group_label,
        tuple(metrics),
        tuple(rows),
        with_change,
        level=level if any(r.interval for r in rows) else None,
        significance=stars.alpha if stars and stars.marks else None,
    )


def _filter(
    frame: pd.DataFrame, column: str, keep: Sequence[str] | None, what: str
) -> pd.DataFrame:
    if keep is None:
        return frame
    known = sorted(frame[column].astype(str).unique())
    if what == "pair":  # B-A is the pair A-B, as for the figures
        keep = [swapped_pair(name, known) for name in keep]
    for name in keep:
        if name not in known:
            raise ConfigError(f"unknown {what} {name!r}; the run has {', '.join(known) or 'none'}")
    return frame[frame[column].astype(str).isin(list(keep))]


def distance_table(
    metrics: pd.DataFrame,
    columns: Sequence[str] = _DISTANCE_DEFAULT,
    pairs: Sequence[str] | None = None,
    order: Sequence[str] = (),
    level: float | None = None,
    stars: Stars | None = None,
) -> Table:
    """Table 2 of paper 000 from ``metrics.csv`` rows; methods in ``order``, then the rest;
    ``level``: with the intervals of the rows' ``<m>_lo`` / ``<m>_hi`` columns;
    ``stars``: marking the significant changes."""
    frame = _filter(metrics, "pair", pairs, "pair")
    return _build(
        frame,
        "pair",
        [c for c in columns if c in frame.columns],
        key="table2",
        title="Table 2. Distance errors per pair and method",
        group_label="Pair",
        with_change=True,
        order=order,
        signed=("mean",),  # of signed distance errors
        level=level,
        stars=stars,
    )


def position_table(
    position_metrics: pd.DataFrame,
    columns: Sequence[str] = _POSITION_DEFAULT,
    platforms: Sequence[str] | None = None,
    order: Sequence[str] = (),
    level: float | None = None,
    stars: Stars | None = None,
) -> Table:
    """Table 3 of paper 000 (horizontal position errors) from ``position_metrics.csv`` rows;
    methods in ``order``, then the rest; ``level`` and ``stars`` as :func:`distance_table`."""
    frame = _filter(position_metrics, "platform", platforms, "platform")
    return _build(
        frame,
        "platform",
        [c for c in columns if c in frame.columns],
        key="table3",
        title="Table 3. Horizontal position errors per platform and method",
        group_label="Platform",
        with_change=True,
        order=order,
        level=level,
        stars=stars,
    )


def axis_table(
    run: RunTables,
    columns: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    order: Sequence[str] = (),
) -> Table:
    """Table 3 per axis (``coopproc report --axes``): E/N/U RMS and max of the position
    error, and velocity / attitude RMS where states.csv has a reference
    (:func:`coopproc.report.axis_metrics.axis_metrics`); columns without any value are
    left out."""
    from coopproc.report.axis_metrics import axis_metrics

    frame = axis_metrics(run.positions, run.states, order[1:] if order else None)
    frame = _filter(frame, "platform", platforms, "platform")
    wanted = [c for c in (columns or _AXIS_ALL) if c in frame.columns]
    shown = [c for c in wanted if c == "n" or frame[c].notna().any()]
    return _build(
        frame,
        "platform",
        shown,
        key="table3_axes",
        title="Table 3 per axis. Position errors per axis (E, N, U), velocity and attitude "
        "errors per platform and method",
        group_label="Platform",
        with_change=True,
        order=order,
    )


def nlos_table(
    nlos_scores: pd.DataFrame,
    columns: Sequence[str] = _NLOS_DEFAULT,
    pairs: Sequence[str] | None = None,
    order: Sequence[str] = (),
) -> Table:
    """NLOS detection scores against the reference (``nlos_scores.csv`` rows); methods in
    ``order``, then the rest."""
    frame = nlos_scores if pairs is None else nlos_scores[nlos_scores["pair"].isin(list(pairs))]
    frame = frame[~_fusion_rows(frame)]  # other truth labels: fusion_outlier_table
    return _build(
        frame,
        "pair",
        [c for c in columns if c in frame.columns],
        key="nlos",
        title="NLOS detection against the reference",
        group_label="Pair",
        with_change=False,
        order=order,
    )


def _fusion_rows(frame: pd.DataFrame) -> np.ndarray:
    return frame["method"].astype(str).str.startswith(FUSION_PREFIX).to_numpy(dtype=bool)


def fusion_outlier_table(
    nlos_scores: pd.DataFrame,
    columns: Sequence[str] = _OUTLIER_DEFAULT,
    pairs: Sequence[str] | None = None,
) -> Table:
    """The cooperative fusion's IGG-III decisions against the reference (the
    ``fusion:<method>`` rows of ``nlos_scores.csv``, report/outlier_scores.py): a table of
    its own, its outliers being another label than NLOS; methods in the file's order."""
    frame = nlos_scores if pairs is None else nlos_scores[nlos_scores["pair"].isin(list(pairs))]
    frame = frame[_fusion_rows(frame)]
    frame = frame.rename(columns={"detected": "down_weighted", "events": "rejected"})
    return _build(
        frame,
        "pair",
        [c for c in columns if c in frame.columns],
        key="fusion_outliers",
        title="Fusion outlier decisions (IGG-III) against the reference: > 3 sigma off",
        group_label="Pair",
        with_change=False,
        order=tuple(dict.fromkeys(str(m) for m in frame["method"])),
    )


def _check_metrics(names: Sequence[str]) -> None:
    known = [*_DISTANCE_DEFAULT, *POSITION_ALL, *_AXIS_ALL, *_NLOS_DEFAULT, *_OUTLIER_DEFAULT]
    known += ["tp", "fp", "fn"]
    for name in names:
        if name not in known:
            near = difflib.get_close_matches(name, known, n=1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise ConfigError(
                f"unknown metric {name!r}{hint} (known: {', '.join(dict.fromkeys(known))})"
            )


def run_method_orders(run: RunTables) -> dict[str, tuple[str, ...]]:
    """Row order of each table key (table2, table3, nlos): the run's methods."""
    return {
        "table2": range_methods(run),
        "table3": ("nav", *position_methods(run)),
        "nlos": nlos_methods(run),
    }


def build_tables(
    run: RunTables,
    *,
    metrics: Sequence[str] | None = None,
    pairs: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    axes: bool = False,
    level: float | None = DEFAULT_LEVEL,
    significance: float | None = DEFAULT_SIGNIFICANCE,
) -> list[Table]:
    """Table 2, Table 3 (``axes``: and Table 3 per axis, :func:`axis_table`) and (if the
    run has scores) the NLOS table, filtered as asked.

    ``level``: Table 2 and Table 3 show the confidence intervals at that level (None:
    none); ``significance``: their changes against Observed whose paired comparison has
    a p-value below it are marked (None: none; :mod:`coopproc.report.table_stats`). A
    pair may be named either way round (``B-A`` is ``A-B``).

    ``metrics`` chooses the columns of every table (in the given order; names a table does
    not have are skipped there; ``n`` is shown only if asked for). Rows follow the run's
    method order (:func:`run_method_orders`); every method of the metrics tables is shown.
    A table left without columns or rows is omitted. Unknown metric, pair or platform
    names raise ConfigError.
    """
    if metrics is not None:
        _check_metrics(metrics)
    order = run_method_orders(run)
    if pairs is not None:
        known = sorted(run.metrics["pair"].astype(str).unique())
        pairs = [swapped_pair(p, known) for p in pairs]
    frames = table_frames(run, level, significance, order)
    tables = [
        distance_table(
            frames.metrics,
            metrics or _DISTANCE_DEFAULT,
            pairs,
            order["table2"],
            level=level,
            stars=frames.distance_stars,
        ),
        position_table(
            frames.position_metrics,
            metrics or _POSITION_DEFAULT,
            platforms,
            order["table3"],
            level=level,
            stars=frames.position_stars,
        ),
    ]
    if axes:
        picked = [m for m in metrics or () if m in _AXIS_ALL] or None
        tables.append(axis_table(run, picked, platforms, order["table3"]))
    if run.nlos_scores is not None and len(run.nlos_scores):
        tables.append(nlos_table(run.nlos_scores, metrics or _NLOS_DEFAULT, pairs, order["nlos"]))
        tables.append(fusion_outlier_table(run.nlos_scores, metrics or _OUTLIER_DEFAULT, pairs))
    return [t for t in tables if t.metrics and t.rows]
