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
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.model import METRICS_COLUMNS, POSITION_METRICS_COLUMNS, FloatArray
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


def distance_metrics(ranges: pd.DataFrame, methods: Sequence[str] | None = None) -> pd.DataFrame:
    """Table 2: one row per pair and method (``metrics.csv``, METRICS_COLUMNS).

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
            rows.append({"pair": str(pair), "method": method, **distance_stats(value, reference)})
    out = pd.DataFrame(rows, columns=list(METRICS_COLUMNS))
    out["n"] = out["n"].astype(np.int64)
    return out


def _axis_errors(own: pd.DataFrame, ref: pd.DataFrame | None) -> tuple[FloatArray, FloatArray]:
    """East and north errors of ``own`` against reference rows interpolated to its times."""
    if ref is None or len(ref) < 2:
        nan = np.full(len(own), np.nan)
        return nan, nan
    ref = ref.sort_values("time", kind="stable")
    t_ref = ref["time"].to_numpy(dtype=np.float64)
    t = own["time"].to_numpy(dtype=np.float64)
    outside = (t < t_ref[0]) | (t > t_ref[-1])
    errors = []
    for axis in ("east", "north"):
        truth = np.interp(t, t_ref, ref[axis].to_numpy(dtype=np.float64))
        truth[outside] = np.nan
        errors.append(own[axis].to_numpy(dtype=np.float64) - truth)
    return errors[0], errors[1]


def _rms(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def position_metrics(positions: pd.DataFrame, methods: Sequence[str] | None = None) -> pd.DataFrame:
    """Table 3: one row per platform and method (``position_metrics.csv``).

    Columns: POSITION_METRICS_COLUMNS then :data:`POSITION_METRICS_EXTRA_COLUMNS`. Statistics
    of the horizontal error ``error_h`` (2D norm) over the epochs that have one; rows of
    method ``reference`` are not scored, they give the per-axis errors. Every method with
    rows is scored; sorted by platform, then ``nav``, ``methods`` (the run's position
    methods; by default :func:`~coopproc.report.methods.position_methods_of`), then any
    other method alphabetically.
    """
    columns = [*POSITION_METRICS_COLUMNS, *POSITION_METRICS_EXTRA_COLUMNS]
    rows: list[dict[str, object]] = []
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    for platform, group in positions.groupby("platform", sort=True):
        refs = group[group["method"] == REFERENCE_METHOD]
        ref = refs if len(refs) else None
        present = sorted(str(m) for m in group["method"].unique() if m != REFERENCE_METHOD)
        for method in method_order(present, order):
            own = group[group["method"] == method].sort_values("time", kind="stable")
            h = own["error_h"].to_numpy(dtype=np.float64, na_value=np.nan)
            h = h[np.isfinite(h)]
            de, dn = _axis_errors(own, ref)
            n = int(h.size)
            stats: dict[str, object] = {"platform": str(platform), "method": method, "n": n}
            if n:
                stats.update(
                    max=float(np.max(h)),
                    mean=float(np.mean(h)),
                    rmse=_rms(h),
                    cep50=float(np.percentile(h, 50)),
                    cep95=float(np.percentile(h, 95)),
                )
            stats.update(rms_east=_rms(de), rms_north=_rms(dn))
            rows.append(stats)
    out = pd.DataFrame(rows, columns=columns)
    out["n"] = out["n"].astype(np.int64)
    return out
