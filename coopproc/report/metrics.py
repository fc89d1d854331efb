"""The statistics of paper 000 Table 2 and Table 3, computed from the output tables.

Pure functions: they take the output tables (columns of :mod:`coopproc.model`) and return
new tables; nothing is read, written or printed. The exact definitions (DATA.md
"Statistics", restated in ``docs/report.md``):

Distance series (per pair and method), over the n epochs having both a value d_i and a
reference distance r_i, in time order, with e_i = d_i - r_i:

- ``max`` = max |e_i|; ``mean`` = (1/n) sum e_i (signed); ``rmse`` = sqrt((1/n) sum e_i^2)
  (population, divisor n);
- ``snr_db`` = 10 log10(sum r_i^2 / sum e_i^2);
- ``smoothness`` = sum (d_{i+1} - d_i)^2 / sum (r_{i+1} - r_i)^2 over consecutive epochs of
  those n (1.0: as smooth as the truth).

Positions (per platform and method), over the epochs with a horizontal error
h_i = ``error_h`` (the 2D norm, never signed): ``max``, ``mean``, ``rmse`` of h_i, plus the
extension columns ``rms_east`` / ``rms_north`` (population RMS of the per-axis error
against the reference rows, when ``positions`` holds rows of method ``reference``) and
``cep50`` / ``cep95`` (the 50th / 95th percentile of h_i, linear interpolation between
order statistics).

With a confidence ``level`` both tables append the block-bootstrap intervals of their
statistics (``<stat>_lo``, ``<stat>_hi``; :mod:`coopproc.report.intervals`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import METRICS_COLUMNS, POSITION_METRICS_COLUMNS, FloatArray
from coopproc.report.intervals import (
    DISTANCE_INTERVAL_STATS,
    POSITION_INTERVAL_STATS,
    distance_intervals,
    interval_columns,
    position_intervals,
)
from coopproc.report.methods import method_order, position_methods_of, range_methods_of
from coopproc.report.scores import nlos_scores

__all__ = [
    "POSITION_METRICS_EXTRA_COLUMNS",
    "REFERENCE_METHOD",
    "distance_metrics",
    "distance_stats",
    "nlos_scores",
    "position_metrics",
]

#: Method name of reference rows in ``positions`` (an extension of DATA.md: the reference
#: trajectory at its own epochs, used for per-axis errors and the trajectory figure).
REFERENCE_METHOD = "reference"

#: Columns position_metrics adds after the contract ones.
POSITION_METRICS_EXTRA_COLUMNS: tuple[str, ...] = ("rms_east", "rms_north", "cep50", "cep95")


def distance_stats(value_m: FloatArray, reference_m: FloatArray) -> dict[str, float]:
    """Table 2 statistics of one distance series against its reference (paper 000, Table 2).

    Epochs where either array is NaN are dropped first; the remaining ones are taken in the
    given (time) order. Returns ``max, mean, rmse, snr_db, smoothness, n``; NaN where a
    statistic is undefined (no epochs; fewer than two for smoothness; a constant reference
    distance for smoothness); ``snr_db`` is ``inf`` for an error-free series.
    """
    d = np.asarray(value_m, dtype=np.float64)
    r = np.asarray(reference_m, dtype=np.float64)
    keep = np.isfinite(d) & np.isfinite(r)
    d, r = d[keep], r[keep]
    n = int(d.shape[0])
    if n == 0:
        nan = float("nan")
        return {"max": nan, "mean": nan, "rmse": nan, "snr_db": nan, "smoothness": nan, "n": 0}
    e = d - r
    sse = float(np.sum(e * e))
    signal = float(np.sum(r * r))
    with np.errstate(divide="ignore"):
        snr_db = float(10.0 * np.log10(signal / sse)) if sse > 0 else float("inf")
    smoothness = float("nan")
    if n >= 2:
        rough_ref = float(np.sum(np.diff(r) ** 2))
        if rough_ref > 0:
            smoothness = float(np.sum(np.diff(d) ** 2)) / rough_ref
    return {
        "max": float(np.max(np.abs(e))),
        "mean": float(np.mean(e)),
        "rmse": float(np.sqrt(sse / n)),
        "snr_db": snr_db,
        "smoothness": smoothness,
        "n": n,
    }


def distance_metrics(
    ranges: pd.DataFrame, methods: Sequence[str] | None = None, *, level: float | None = None
) -> pd.DataFrame:
    """Table 2: one row per pair and method (``metrics.csv``, METRICS_COLUMNS; ``level``:
    then the ``<stat>_lo`` / ``<stat>_hi`` intervals of
    :data:`~coopproc.report.intervals.DISTANCE_INTERVAL_STATS` at that confidence level,
    :func:`~coopproc.report.intervals.distance_intervals`).

    Every range method column of ``ranges`` is scored against ``reference``: ``methods``
    (the run's, e.g. :func:`~coopproc.report.methods.range_methods`), by default those
    derived from the columns (:func:`~coopproc.report.methods.range_methods_of`). Rows are
    sorted by pair, then methods in that order; a pair without any reference gives rows
    with n = 0.
    """
    methods = range_methods_of(ranges) if methods is None else tuple(methods)
    missing = [c for c in ("time", "pair", "reference", *methods) if c not in ranges.columns]
    if missing:
        raise ValueError(f"ranges table lacks columns {missing}")
    rows: list[dict[str, object]] = []
    # rows by pair, then time (stable), as index arrays: no sorted copy of the whole table
    codes, pairs = pd.factorize(ranges["pair"], sort=True)
    time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    order = np.lexsort((time, codes))
    order = order[codes[order] >= 0]  # rows without a pair are in no group
    bounds = np.searchsorted(codes[order], np.arange(len(pairs) + 1))
    reference_all = ranges["reference"].to_numpy(dtype=np.float64, na_value=np.nan)
    values = {m: ranges[m].to_numpy(dtype=np.float64, na_value=np.nan) for m in methods}
    for k, pair in enumerate(pairs):
        at = order[bounds[k] : bounds[k + 1]]
        reference = reference_all[at]
        for method in methods:
            value = values[method][at]
            row = {"pair": str(pair), "method": method, **distance_stats(value, reference)}
            if level is not None:
                row.update(distance_intervals(value, reference, level, (str(pair), method)))
            rows.append(row)
    columns = list(METRICS_COLUMNS)
    if level is not None:
        columns += interval_columns(DISTANCE_INTERVAL_STATS)
    out = pd.DataFrame(rows, columns=columns)
    out["n"] = out["n"].astype(np.int64)
    return out


def _axis_errors(
    time_s: FloatArray, east: FloatArray, north: FloatArray, ref: _Rows | None
) -> tuple[FloatArray, FloatArray]:
    """East and north errors against reference rows (time-sorted) interpolated to ``time_s``."""
    if ref is None or ref[0].shape[0] < 2:
        nan = np.full(time_s.shape[0], np.nan)
        return nan, nan
    t_ref, ref_east, ref_north = ref
    outside = (time_s < t_ref[0]) | (time_s > t_ref[-1])
    errors = []
    for own, axis in ((east, ref_east), (north, ref_north)):
        truth = np.interp(time_s, t_ref, axis)
        truth[outside] = np.nan
        errors.append(own - truth)
    return errors[0], errors[1]


def _rms(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


#: One group's rows: time, east, north (time-sorted, stable).
_Rows = tuple[FloatArray, FloatArray, FloatArray]


def _codes(column: pd.Series) -> tuple[NDArray[np.integer], list[str]]:
    """Integer codes (-1: missing) and sorted names (categories' order when categorical,
    as ``groupby`` orders them; a categorical's codes are taken as they are)."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        return column.cat.codes.to_numpy(), [str(n) for n in column.cat.categories]
    codes, names = pd.factorize(column, sort=True)
    return np.asarray(codes), [str(n) for n in names]


def _group_rows(
    platform: NDArray[np.integer], method: NDArray[np.integer], time_s: FloatArray
) -> dict[tuple[int, int], slice | NDArray[np.intp]]:
    """Rows of each (platform, method) code pair, in time order (stable), original order
    for ties: a slice when the group is one run already in time order (positions.csv as
    built, platform-major), else row indices. No sorted copy of the table."""
    n = platform.shape[0]
    if n == 0:
        return {}
    change = np.flatnonzero((platform[1:] != platform[:-1]) | (method[1:] != method[:-1])) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change, [n]))
    keys = list(zip(platform[starts].tolist(), method[starts].tolist(), strict=True))
    out: dict[tuple[int, int], slice | NDArray[np.intp]] = {}
    if len(set(keys)) == len(keys):  # every group is one contiguous run
        for key, lo, hi in zip(keys, starts.tolist(), ends.tolist(), strict=True):
            out[key] = slice(lo, hi)
    else:
        order = np.argsort(
            platform.astype(np.int64) * (int(method.max()) + 2) + method, kind="stable"
        )
        for key in sorted(set(keys)):
            at = order[(platform[order] == key[0]) & (method[order] == key[1])]
            out[key] = at
    for key, rows in out.items():
        t = time_s[rows]
        if t.shape[0] > 1 and not bool(np.all(t[1:] >= t[:-1])):
            at = np.arange(rows.start, rows.stop) if isinstance(rows, slice) else rows
            out[key] = at[np.argsort(t, kind="stable")]
    return out


def position_metrics(
    positions: pd.DataFrame, methods: Sequence[str] | None = None, *, level: float | None = None
) -> pd.DataFrame:
    """Table 3: one row per platform and method (``position_metrics.csv``).

    Columns: POSITION_METRICS_COLUMNS then :data:`POSITION_METRICS_EXTRA_COLUMNS` (then,
    with ``level``, the intervals of
    :data:`~coopproc.report.intervals.POSITION_INTERVAL_STATS`:
    :func:`~coopproc.report.intervals.position_intervals`). Statistics
    of the horizontal error ``error_h`` (2D norm) over the epochs that have one; rows of
    method ``reference`` are not scored, they give the per-axis errors. Every method with
    rows is scored; sorted by platform, then ``nav``, ``methods`` (the run's position
    methods; by default :func:`~coopproc.report.methods.position_methods_of`), then any
    other method alphabetically. Groups are found from integer codes of ``platform`` and
    ``method`` (no per-group copies of the table, no string comparison per row).
    """
    columns = [*POSITION_METRICS_COLUMNS, *POSITION_METRICS_EXTRA_COLUMNS]
    if level is not None:
        columns += interval_columns(POSITION_INTERVAL_STATS)
    rows: list[dict[str, object]] = []
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    platform, platform_names = _codes(positions["platform"])
    method, method_names = _codes(positions["method"])
    values = {
        c: positions[c].to_numpy(dtype=np.float64, na_value=np.nan)
        for c in ("time", "east", "north", "error_h")
    }
    groups = _group_rows(platform, method, values["time"])
    ref_code = method_names.index(REFERENCE_METHOD) if REFERENCE_METHOD in method_names else -2
    for p, name in enumerate(platform_names):
        mine = {method_names[m]: rows_ for (q, m), rows_ in groups.items() if q == p and m >= 0}
        if not mine:
            continue
        at = groups.get((p, ref_code))
        ref = None if at is None else (values["time"][at], values["east"][at], values["north"][at])
        present = sorted(m for m in mine if m != REFERENCE_METHOD)
        for method_name in method_order(present, order):
            own = mine[method_name]
            h_all = values["error_h"][own]
            h = h_all[np.isfinite(h_all)]
            de, dn = _axis_errors(
                values["time"][own], values["east"][own], values["north"][own], ref
            )
            if level is not None:
                bounds = position_intervals(h_all, de, dn, level, (name, method_name))
            n = int(h.size)
            stats: dict[str, object] = {"platform": name, "method": method_name, "n": n}
            if n:
                stats.update(
                    max=float(np.max(h)),
                    mean=float(np.mean(h)),
                    rmse=_rms(h),
                    cep50=float(np.percentile(h, 50)),
                    cep95=float(np.percentile(h, 95)),
                )
            stats.update(rms_east=_rms(de), rms_north=_rms(dn))
            if level is not None:
                stats.update(bounds)
            rows.append(stats)
    out = pd.DataFrame(rows, columns=columns)
    out["n"] = out["n"].astype(np.int64)
    return out
