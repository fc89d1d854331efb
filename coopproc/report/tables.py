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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError
from coopproc.model import METRICS_COLUMNS
from coopproc.report.change import Change, change_of
from coopproc.report.methods import method_order, nlos_methods, position_methods, range_methods
from coopproc.report.metrics import POSITION_METRICS_EXTRA_COLUMNS
from coopproc.report.outlier_scores import FUSION_PREFIX
from coopproc.report.rundir import RunTables

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

Better = Literal["min", "max", "absmin", "one"]

#: Display names of methods (paper 000 names RN-Based and DI-Based).
METHOD_LABELS: dict[str, str] = {
    "observed": "Observed",
    "rn": "RN-Based",
    "di": "DI-Based",
    "nav": "Own nav",
}


def method_label(method: str) -> str:
    """The display name of a method: :data:`METHOD_LABELS`, else the method's own name."""
    return METHOD_LABELS.get(method, method)


def number_text(name: str, value: float) -> str:
    """A statistic's value as the tables print it: the decimals of its :class:`MetricSpec`,
    ``-`` for NaN, ``inf`` / ``-inf``."""
    if value != value:  # NaN
        return "-"
    if value in (float("inf"), float("-inf")):
        return "inf" if value > 0 else "-inf"
    return f"{value:.{METRIC_SPECS.get(name, MetricSpec(name)).decimals}f}"


@dataclass(frozen=True)
class MetricSpec:
    """How one statistic is shown: header label, unit, decimals, which value is best."""

    label: str
    unit: str = ""
    decimals: int = 4
    #: min / max: smallest / largest; absmin: smallest magnitude; one: closest to 1.
    better: Better | None = "min"
    #: The statistic can be negative (a bias): its change against Observed is absolute.
    signed: bool = False


METRIC_SPECS: dict[str, MetricSpec] = {
    "max": MetricSpec("Max", "m"),
    "mean": MetricSpec("Mean", "m", better="absmin"),
    "rmse": MetricSpec("RMSE", "m"),
    "snr_db": MetricSpec("SNR", "dB", 2, "max"),
    "smoothness": MetricSpec("Smoothness", "", 4, "one"),
    "rms_east": MetricSpec("RMS E", "m"),
    "rms_north": MetricSpec("RMS N", "m"),
    "cep50": MetricSpec("CEP50", "m"),
    "cep95": MetricSpec("CEP95", "m"),
    # Table 3 per axis (coopproc.report.axis_metrics)
    "rms_up": MetricSpec("RMS U", "m"),
    "max_east": MetricSpec("Max E", "m"),
    "max_north": MetricSpec("Max N", "m"),
    "max_up": MetricSpec("Max U", "m"),
    "rms_vel_east": MetricSpec("RMS vE", "m/s"),
    "rms_vel_north": MetricSpec("RMS vN", "m/s"),
    "rms_vel_up": MetricSpec("RMS vU", "m/s"),
    "rms_roll": MetricSpec("RMS roll", "deg", 3),
    "rms_pitch": MetricSpec("RMS pitch", "deg", 3),
    "rms_yaw": MetricSpec("RMS yaw", "deg", 3),
    "precision": MetricSpec("Precision", "", 3, "max"),
    "recall": MetricSpec("Recall", "", 3, "max"),
    "f1": MetricSpec("F1", "", 3, "max"),
    "events": MetricSpec("Events", "", 0, None),
    "estimate_mae": MetricSpec("Est. MAE", "m"),
    "n": MetricSpec("n", "", 0, None),
    # the fusion's outlier decisions (report/outlier_scores.py): nlos_scores.csv's
    # ``detected`` and ``events`` of the fusion:<method> rows
    "down_weighted": MetricSpec("Down-weighted", "", 0, None),
    "rejected": MetricSpec("Rejected", "", 0, None),
}

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


@dataclass(frozen=True)
class Row:
    """One method of one group: values, change vs observed (None: not shown), best cells."""

    group: str
    method: str
    values: dict[str, float]
    change: dict[str, Change | None]
    best: frozenset[str]


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

    def header(self, name: str) -> str:
        """Column header with the unit, e.g. ``Max (m)``."""
        spec = METRIC_SPECS.get(name, MetricSpec(name))
        return f"{spec.label} ({spec.unit})" if spec.unit else spec.label


def _change(name: str, value: float, observed: float, signed: Sequence[str]) -> Change | None:
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


def _best(name: str, values: list[float]) -> set[int]:
    better = METRIC_SPECS.get(name, MetricSpec(name)).better
    arr = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(arr)
    if better is None or np.count_nonzero(ok) < 2:
        return set()
    score = {"min": arr, "max": -arr, "absmin": np.abs(arr), "one": np.abs(arr - 1.0)}[better]
    best = np.min(score[ok])
    winners = ok & np.isclose(score, best, rtol=0, atol=1e-12)
    if np.array_equal(winners, ok):
        return set()  # all equal: nothing is best
    return {int(i) for i in np.flatnonzero(winners)}


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
) -> Table:
    rows: list[Row] = []
    for group, block in frame.groupby(group_col, sort=True):
        records = block.to_dict("records")
        ranked = method_order([str(r["method"]) for r in records], order)
        records.sort(key=lambda r: ranked.index(str(r["method"])))
        observed = next((r for r in records if r["method"] == "observed"), None)
        best = {m: _best(m, [float(r[m]) for r in records]) for m in metrics}
        for i, rec in enumerate(records):
            values = {m: float(rec[m]) for m in metrics}
            change: dict[str, Change | None] = {m: None for m in metrics}
            if with_change and observed is not None and rec["method"] != "observed":
                change = {m: _change(m, values[m], float(observed[m]), signed) for m in metrics}
            rows.append(
                Row(
                    group=str(group),
                    method=str(rec["method"]),
                    values=values,
                    change=change,
                    best=frozenset(m for m in metrics if i in best[m]),
                )
            )
    return Table(key, title, group_label, tuple(metrics), tuple(rows), with_change)


def _filter(
    frame: pd.DataFrame, column: str, keep: Sequence[str] | None, what: str
) -> pd.DataFrame:
    if keep is None:
        return frame
    known = sorted(frame[column].astype(str).unique())
    for name in keep:
        if name not in known:
            raise ConfigError(f"unknown {what} {name!r}; the run has {', '.join(known) or 'none'}")
    return frame[frame[column].astype(str).isin(list(keep))]


def distance_table(
    metrics: pd.DataFrame,
    columns: Sequence[str] = _DISTANCE_DEFAULT,
    pairs: Sequence[str] | None = None,
    order: Sequence[str] = (),
) -> Table:
    """Table 2 of paper 000 from ``metrics.csv`` rows; methods in ``order``, then the rest."""
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
    )


def position_table(
    position_metrics: pd.DataFrame,
    columns: Sequence[str] = _POSITION_DEFAULT,
    platforms: Sequence[str] | None = None,
    order: Sequence[str] = (),
) -> Table:
    """Table 3 of paper 000 (horizontal position errors) from ``position_metrics.csv`` rows;
    methods in ``order``, then the rest."""
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
) -> list[Table]:
    """Table 2, Table 3 (``axes``: and Table 3 per axis, :func:`axis_table`) and (if the
    run has scores) the NLOS table, filtered as asked.

    ``metrics`` chooses the columns of every table (in the given order; names a table does
    not have are skipped there; ``n`` is shown only if asked for). Rows follow the run's
    method order (:func:`run_method_orders`); every method of the metrics tables is shown.
    A table left without columns or rows is omitted. Unknown metric, pair or platform
    names raise ConfigError.
    """
    if metrics is not None:
        _check_metrics(metrics)
    order = run_method_orders(run)
    tables = [
        distance_table(run.metrics, metrics or _DISTANCE_DEFAULT, pairs, order["table2"]),
        position_table(
            run.position_metrics, metrics or _POSITION_DEFAULT, platforms, order["table3"]
        ),
    ]
    if axes:
        picked = [m for m in metrics or () if m in _AXIS_ALL] or None
        tables.append(axis_table(run, picked, platforms, order["table3"]))
    if run.nlos_scores is not None and len(run.nlos_scores):
        tables.append(nlos_table(run.nlos_scores, metrics or _NLOS_DEFAULT, pairs, order["nlos"]))
        tables.append(fusion_outlier_table(run.nlos_scores, metrics or _OUTLIER_DEFAULT, pairs))
    return [t for t in tables if t.metrics and t.rows]
