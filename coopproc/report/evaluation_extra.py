"""``evaluation.csv``'s columns beyond evo's APE: coverage, along / cross-track errors and
the confidence interval of every statistic (appended after the columns of
:mod:`coopproc.report.evaluation`, in :data:`EXTRA_COLUMNS` order).

- **coverage**: the share of the platform's ``reference`` epochs that the method
  positioned, an epoch counting as positioned when one of the method's evaluation
  epochs lies within half its gap limit (:func:`coopproc.model.gap_limit_s`: 2.5 x its
  median interval) of it. APE and RMSE are blind to lost tracking: a method that stops
  positioning when it is hard keeps a small RMSE; its coverage says so.
- **along / cross-track** (trajectopy's, not evo's): the error projected on the
  horizontal direction of travel of the reference, ``u`` = the unit vector of the
  reference's east/north velocity (central differences over the matched epochs):
  ``along = d . u`` (positive: ahead), ``cross = u_e d_n - u_n d_e`` (positive: left of
  the track). Epochs where the reference moves slower than :data:`MIN_SPEED_MPS` have
  no direction and are left out. ``rms_``, ``mean_`` (signed) and ``absmax_`` of each;
  the vertical is ``up`` (``rms_up``, ``mean_up`` of evaluation.csv).
- **intervals** ``<stat>_lo`` / ``<stat>_hi`` at 95 % of :data:`INTERVAL_STATS`, the
  block bootstrap of :mod:`coopproc.report.bootstrap` over the matched epochs (blocks
  from the 3-D error's autocorrelation; medians: Woodruff's interval). For an alignment
  other than ``none`` the transform is held fixed (the interval is conditional on it).
  Min, max and absmax have none (extremes), nor the transform.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, gap_limit_s
from coopproc.report.bootstrap import (
    DEFAULT_LEVEL,
    DEFAULT_RESAMPLES,
    MIN_EPOCHS,
    block_length,
    draw_blocks,
    generator,
    interval,
    quantile_interval,
    resampled_sums,
    spread,
    variance_ratio,
)
from coopproc.report.tracks import REFERENCE_METHOD, codes_of, float_column, groups_of

__all__ = [
    "EXTRA_COLUMNS",
    "GEOMETRY_COLUMNS",
    "INTERVAL_STATS",
    "MIN_SPEED_MPS",
    "coverage",
    "coverage_map",
    "evaluation_extras",
    "track_errors",
]

#: Slower than this the reference has no direction of travel (m/s).
MIN_SPEED_MPS = 0.05
GEOMETRY_COLUMNS: tuple[str, ...] = (
    "coverage",
    "rms_along",
    "rms_cross",
    "mean_along",
    "mean_cross",
    "absmax_along",
    "absmax_cross",
)
#: The statistics of evaluation.csv with an interval.
INTERVAL_STATS: tuple[str, ...] = (
    *(f"{s}_{k}" for k in ("3d", "h") for s in ("rmse", "mean", "median", "std")),
    *(f"{s}_{a}" for s in ("rms", "mean", "std") for a in ("east", "north", "up")),
    *(f"{s}_{a}" for s in ("rms", "mean") for a in ("along", "cross")),
)
#: Every column this module appends, in order.
EXTRA_COLUMNS: tuple[str, ...] = (
    *GEOMETRY_COLUMNS,
    *(f"{s}_{end}" for s in INTERVAL_STATS for end in ("lo", "hi")),
)


def coverage(ref_time: FloatArray, method_time: FloatArray) -> float:
    """The share of ``ref_time`` (sorted) positioned by ``method_time`` (sorted; module
    doc); NaN without reference epochs."""
    r = np.asarray(ref_time, dtype=np.float64)
    m = np.asarray(method_time, dtype=np.float64)
    if not r.shape[0]:
        return float("nan")
    if not m.shape[0]:
        return 0.0
    tol = 0.5 * gap_limit_s(m) if m.shape[0] > 1 else 0.5
    at = np.clip(np.searchsorted(m, r), 1, max(m.shape[0] - 1, 1))
    nearest = np.minimum(np.abs(r - m[at - 1]), np.abs(m[np.minimum(at, m.shape[0] - 1)] - r))
    return float(np.mean(nearest <= tol))


def coverage_map(positions: pd.DataFrame) -> dict[tuple[str, str], float]:
    """:func:`coverage` of every platform and method of ``positions.csv`` (the method's
    epochs with an ``error_h``, the platform's ``reference`` rows)."""
    if not len(positions):
        return {}
    platform_codes, platforms = codes_of(positions["platform"])
    method_codes, methods = codes_of(positions["method"])
    time = float_column(positions, "time")
    error = float_column(positions, "error_h")
    groups: dict[int, dict[str, FloatArray]] = {}
    for p, m, rows in groups_of(platform_codes, method_codes):
        t = time[rows]
        if methods[m] != REFERENCE_METHOD:
            t = t[np.isfinite(error[rows])]
        groups.setdefault(p, {})[methods[m]] = np.sort(t)
    out: dict[tuple[str, str], float] = {}
    for p, by_method in groups.items():
        ref = by_method.get(REFERENCE_METHOD, np.empty(0))
        for method, t in by_method.items():
            if method != REFERENCE_METHOD:
                out[(platforms[p], method)] = coverage(ref, t)
    return out


def track_errors(time_s: FloatArray, moved: FloatArray, ref: FloatArray) -> FloatArray:
    """Along- and cross-track errors (n, 2) of ``moved - ref`` (module doc; NaN where the
    reference has no direction)."""
    n = time_s.shape[0]
    out = np.full((n, 2), np.nan)
    if n < 2:
        return out
    t = np.asarray(time_s, dtype=np.float64)
    if not bool(np.all(np.diff(t) > 0)):
        return out
    v = np.stack([np.gradient(ref[:, k], t) for k in (0, 1)], axis=1)
    speed = np.hypot(v[:, 0], v[:, 1])
    ok = speed >= MIN_SPEED_MPS
    u = v[ok] / speed[ok, None]
    d = moved[ok, :2] - ref[ok, :2]
    out[ok, 0] = d[:, 0] * u[:, 0] + d[:, 1] * u[:, 1]
    out[ok, 1] = u[:, 0] * d[:, 1] - u[:, 1] * d[:, 0]
    return out


def _geometry(along_cross: FloatArray) -> dict[str, float]:
    out: dict[str, float] = {}
    for k, name in enumerate(("along", "cross")):
        x = along_cross[:, k]
        x = x[np.isfinite(x)]
        empty = not x.size
        out[f"rms_{name}"] = float("nan") if empty else float(np.sqrt(np.mean(x * x)))
        out[f"mean_{name}"] = float("nan") if empty else float(np.mean(x))
        out[f"absmax_{name}"] = float("nan") if empty else float(np.max(np.abs(x)))
    return out


def _moments(
    out: dict[str, float],
    x: FloatArray,
    names: tuple[str, str, str | None],
    blocks_n: tuple[int, int],
    level: float,
    seed: Sequence[str],
) -> None:
    """Intervals of the RMS, mean and (if named) std of ``x`` (finite values, time order)."""
    rms_name, mean_name, std_name = names
    x = x[np.isfinite(x)]
    if x.shape[0] < MIN_EPOCHS:
        return
    length = max(blocks_n[0], 1) if x.shape[0] == blocks_n[1] else block_length(x)
    blocks = draw_blocks(x.shape[0], length, DEFAULT_RESAMPLES, generator(*seed, rms_name))
    sums = resampled_sums(blocks, np.column_stack((x, x * x))) / blocks.size
    ratio = math.sqrt(variance_ratio(x, blocks.length))
    ratio2 = math.sqrt(variance_ratio(x * x, blocks.length))
    m1, m2 = float(np.mean(x)), float(np.mean(x * x))
    with np.errstate(invalid="ignore"):
        star_rms = np.sqrt(sums[:, 1])
        star_std = np.sqrt(np.maximum(sums[:, 1] - sums[:, 0] ** 2, 0.0))
    pairs: list[tuple[str, float, FloatArray, float]] = [
        (rms_name, math.sqrt(m2), star_rms, ratio2),
        (mean_name, m1, sums[:, 0], ratio),
    ]
    if std_name is not None:
        pairs.append((std_name, math.sqrt(max(m2 - m1 * m1, 0.0)), star_std, ratio2))
    for name, value, star, r in pairs:
        out[f"{name}_lo"], out[f"{name}_hi"] = interval(value, spread(star) * r, level, blocks.dof)


def evaluation_extras(
    time_s: FloatArray,
    moved: FloatArray,
    ref: FloatArray,
    covered: float,
    names: Sequence[str],
    level: float = DEFAULT_LEVEL,
) -> dict[str, float]:
    """The :data:`EXTRA_COLUMNS` of one evaluation row: ``moved`` / ``ref`` (n, 3) at the
    matched epochs in time order (``moved`` all NaN: an undetermined alignment),
    ``covered`` its coverage, ``names`` the seed (platform, method, alignment)."""
    out: dict[str, float] = dict.fromkeys(EXTRA_COLUMNS, float("nan"))
    out["coverage"] = covered
    if not moved.shape[0] or not np.isfinite(moved).any():
        return out
    d = moved - ref
    along_cross = track_errors(time_s, moved, ref)
    out.update(_geometry(along_cross))
    e3 = np.sqrt(np.sum(d * d, axis=1))
    h = np.hypot(d[:, 0], d[:, 1])
    n = int(e3.shape[0])
    if n < MIN_EPOCHS:
        return out
    b = block_length(e3)
    seed = tuple(names)
    for x, tag in ((e3, "3d"), (h, "h")):
        _moments(out, x, (f"rmse_{tag}", f"mean_{tag}", f"std_{tag}"), (b, n), level, seed)
        blocks = draw_blocks(n, b, DEFAULT_RESAMPLES, generator(*seed, f"median_{tag}"))
        below = (x <= np.median(x)).astype(np.float64)
        ratio = variance_ratio(below, blocks.length)
        lo, hi = quantile_interval(x, 0.5, blocks, level, ratio)
        out[f"median_{tag}_lo"], out[f"median_{tag}_hi"] = lo, hi
    for k, axis in enumerate(("east", "north", "up")):
        names_k = (f"rms_{axis}", f"mean_{axis}", f"std_{axis}")
        _moments(out, d[:, k], names_k, (b, n), level, seed)
    for k, axis in enumerate(("along", "cross")):
        _moments(out, along_cross[:, k], (f"rms_{axis}", f"mean_{axis}", None), (b, n), level, seed)
    return out
