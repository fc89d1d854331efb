"""Confidence intervals of Table 2 / Table 3 statistics and paired comparisons of methods
(the moving-block bootstrap of :mod:`coopproc.report.bootstrap`).

Per series (one pair and method of Table 2, one platform and method of Table 3) the
columns ``<stat>_lo`` / ``<stat>_hi`` of :data:`DISTANCE_INTERVAL_STATS` /
:data:`POSITION_INTERVAL_STATS` at the given level, appended to ``metrics.csv`` /
``position_metrics.csv`` (``max`` has none: :mod:`~coopproc.report.bootstrap`). The blocks
are those of the series' error (``e_i`` of Table 2, ``h_i`` of Table 3).

A **paired comparison** of a method against a baseline (``observed``; ``di`` against
``rn``) of the same pair / platform takes the epochs both have (Table 2: the same range
rows with both values and a reference; Table 3: the same times), draws ONE set of blocks
(the longer of the two errors' block lengths) and evaluates both methods' statistics on
it, so the resampled difference keeps their correlation: the difference of RMSE and of
mean error (Table 2: the signed mean, as the change column; Table 3: the mean of h), its
percentile interval and two-sided p-value (``comparisons.csv``,
:data:`COMPARISON_COLUMNS`). On the epochs both have, so the difference can differ from
the tables' when one method has epochs the other lacks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.bootstrap import (
    DEFAULT_RESAMPLES,
    MIN_EPOCHS,
    Blocks,
    block_length,
    draw_blocks,
    generator,
    interval,
    p_value,
    quantile_interval,
    resampled_sums,
    spread,
    variance_ratio,
)

__all__ = [
    "COMPARISON_COLUMNS",
    "DISTANCE_INTERVAL_STATS",
    "POSITION_INTERVAL_STATS",
    "comparison_frame",
    "comparison_pairs",
    "distance_intervals",
    "interval_columns",
    "paired_difference",
    "position_intervals",
]

#: Table 2 statistics with an interval (metrics.csv ``<stat>_lo``, ``<stat>_hi``).
DISTANCE_INTERVAL_STATS: tuple[str, ...] = ("mean", "rmse", "snr_db", "smoothness")
#: Table 3 statistics with an interval (position_metrics.csv).
POSITION_INTERVAL_STATS: tuple[str, ...] = (
    "mean",
    "rmse",
    "rms_east",
    "rms_north",
    "cep50",
    "cep95",
)
#: Columns of ``comparisons.csv``: ``kind`` (pair / platform), ``group`` (its name),
#: ``method`` against ``baseline``; ``n`` common epochs, ``block`` length (epochs);
#: ``<stat>_diff`` = method's minus baseline's, its interval and p-value.
COMPARISON_COLUMNS: tuple[str, ...] = (
    "kind",
    "group",
    "method",
    "baseline",
    "n",
    "block",
    "rmse_diff",
    "rmse_diff_lo",
    "rmse_diff_hi",
    "rmse_p",
    "mean_diff",
    "mean_diff_lo",
    "mean_diff_hi",
    "mean_p",
)


def interval_columns(stats: Sequence[str]) -> tuple[str, ...]:
    """``<stat>_lo, <stat>_hi`` of each statistic, in order."""
    return tuple(f"{s}_{end}" for s in stats for end in ("lo", "hi"))


def _nan(stats: Sequence[str]) -> dict[str, float]:
    return dict.fromkeys(interval_columns(stats), float("nan"))


def _put(
    out: dict[str, float],
    stat: str,
    value: float,
    samples: FloatArray,
    series: FloatArray,
    blocks: Blocks,
    level: float,
) -> None:
    """``<stat>_lo`` / ``<stat>_hi``: ``value +- t sd`` with the resamples' spread
    corrected by the variance ratio of ``series``, the statistic's per-epoch input."""
    sd = spread(samples) * math.sqrt(variance_ratio(series, blocks.length))
    out[f"{stat}_lo"], out[f"{stat}_hi"] = interval(value, sd, level, blocks.dof)


def _blocks(series: FloatArray, resamples: int, *names: str, least: int = 1) -> Blocks:
    n = int(series.shape[0])
    length = max(block_length(series), least)
    return draw_blocks(n, length, resamples, generator(*names))


def distance_intervals(
    value_m: FloatArray,
    reference_m: FloatArray,
    level: float,
    names: Sequence[str],
    resamples: int = DEFAULT_RESAMPLES,
) -> dict[str, float]:
    """Intervals of Table 2's mean, rmse, snr_db and smoothness of one series (the epochs
    of :func:`coopproc.report.metrics.distance_stats`, in time order); ``names`` seed the
    generator (pair, method)."""
    d = np.asarray(value_m, dtype=np.float64)
    r = np.asarray(reference_m, dtype=np.float64)
    keep = np.isfinite(d) & np.isfinite(r)
    d, r = d[keep], r[keep]
    n = d.shape[0]
    if n < MIN_EPOCHS:
        return _nan(DISTANCE_INTERVAL_STATS)
    e = d - r
    e2 = e * e
    step_d, step_r = np.diff(d) ** 2, np.diff(r) ** 2
    blocks = _blocks(e, resamples, *names, least=2)  # smoothness: a step in each block
    sums = resampled_sums(blocks, np.column_stack((e, e2, r * r)))
    steps = resampled_sums(blocks, np.column_stack((step_d, step_r)), diffs=True)
    size = float(blocks.size)
    out: dict[str, float] = {}
    sse, signal = float(np.sum(e2)), float(np.sum(r * r))
    with np.errstate(divide="ignore", invalid="ignore"):
        _put(out, "mean", float(np.mean(e)), sums[:, 0] / size, e, blocks, level)
        _put(out, "rmse", math.sqrt(sse / n), np.sqrt(sums[:, 1] / size), e2, blocks, level)
        snr = 10.0 * math.log10(signal / sse) if sse > 0 else float("inf")
        snr_star = 10.0 * np.log10(sums[:, 2] / sums[:, 1])
        _put(out, "snr_db", snr, snr_star, e2, blocks, level)
        rough = float(np.sum(step_r))
        smooth = float(np.sum(step_d)) / rough if rough > 0 else float("nan")
        # a ratio of two sums of squares: its interval on the log scale (never below 0,
        # as skewed as the ratio), exp(log T +- t sd(log T*))
        log_star = np.log(steps[:, 0] / steps[:, 1])
        log_value = math.log(smooth) if smooth > 0 else float("nan")
        _put(out, "smoothness", log_value, log_star, step_d, blocks, level)
        out["smoothness_lo"] = math.exp(out["smoothness_lo"])
        out["smoothness_hi"] = math.exp(out["smoothness_hi"])
    return out


def _rms_bounds(
    out: dict[str, float],
    stat: str,
    x: FloatArray,
    level: float,
    names: Sequence[str],
    resamples: int,
) -> None:
    """``stat``'s interval: the RMS of the finite values of ``x`` (the epochs that have
    one, in time order, with blocks of their own: position_metrics.csv's ``rms_east`` /
    ``rms_north`` count every epoch with a reference row, ``h`` or not)."""
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.shape[0] < MIN_EPOCHS:
        out[f"{stat}_lo"] = out[f"{stat}_hi"] = float("nan")
        return
    sq = x * x
    blocks = _blocks(x, resamples, *names, stat)
    sums = resampled_sums(blocks, sq) / blocks.size
    _put(out, stat, math.sqrt(float(np.mean(sq))), np.sqrt(sums), sq, blocks, level)


def _quantile_bounds(
    out: dict[str, float], stat: str, h: FloatArray, q: float, blocks: Blocks, level: float
) -> None:
    below = (h <= np.quantile(h, q)).astype(np.float64)
    ratio = variance_ratio(below, blocks.length)
    out[f"{stat}_lo"], out[f"{stat}_hi"] = quantile_interval(h, q, blocks, level, ratio)


def position_intervals(
    h: FloatArray,
    east: FloatArray,
    north: FloatArray,
    level: float,
    names: Sequence[str],
    resamples: int = DEFAULT_RESAMPLES,
) -> dict[str, float]:
    """Intervals of Table 3's mean, rmse, rms_east, rms_north, cep50, cep95 of one
    platform and method: ``h`` the horizontal errors, ``east`` / ``north`` the per-axis
    errors (NaN where there is no reference row), all at the method's epochs in time
    order; each statistic over the epochs that have its input, as the table's."""
    out = _nan(POSITION_INTERVAL_STATS)
    _rms_bounds(out, "rms_east", east, level, names, resamples)
    _rms_bounds(out, "rms_north", north, level, names, resamples)
    h = np.asarray(h, dtype=np.float64)
    h = h[np.isfinite(h)]
    if h.shape[0] < MIN_EPOCHS:
        return out
    blocks = _blocks(h, resamples, *names)
    h2 = h * h
    sums = resampled_sums(blocks, np.column_stack((h, h2)))
    size = float(blocks.size)
    _put(out, "mean", float(np.mean(h)), sums[:, 0] / size, h, blocks, level)
    rmse = math.sqrt(float(np.mean(h2)))
    _put(out, "rmse", rmse, np.sqrt(sums[:, 1] / size), h2, blocks, level)
    _quantile_bounds(out, "cep50", h, 0.50, blocks, level)
    _quantile_bounds(out, "cep95", h, 0.95, blocks, level)
    return out


def comparison_pairs(methods: Sequence[str]) -> list[tuple[str, str]]:
    """(method, baseline) compared: each method against ``observed``, ``di`` against
    ``rn``; in the order of ``methods``."""
    out = [(m, "observed") for m in methods if m != "observed" and "observed" in methods]
    if "di" in methods and "rn" in methods:
        out.append(("di", "rn"))
    return out


def paired_difference(
    a: FloatArray,
    b: FloatArray,
    level: float,
    names: Sequence[str],
    resamples: int = DEFAULT_RESAMPLES,
) -> dict[str, float]:
    """The paired comparison of errors ``a`` (method) and ``b`` (baseline) at the same
    epochs, in time order (NaN in either: left out): ``n``, ``block``, the RMSE and mean
    differences (a's minus b's) with interval and p-value (:data:`COMPARISON_COLUMNS`)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    keep = np.isfinite(a) & np.isfinite(b)
    a, b = a[keep], b[keep]
    n = int(a.shape[0])
    out: dict[str, float] = dict.fromkeys(COMPARISON_COLUMNS[4:], float("nan"))
    out["n"] = n
    if n == 0:
        return out
    out["rmse_diff"] = math.sqrt(float(np.mean(a * a))) - math.sqrt(float(np.mean(b * b)))
    out["mean_diff"] = float(np.mean(a)) - float(np.mean(b))
    if n < MIN_EPOCHS:
        return out
    length = max(block_length(a), block_length(b))
    blocks = draw_blocks(n, length, resamples, generator(*names))
    out["block"] = blocks.length
    a2, b2 = a * a, b * b
    sums = resampled_sums(blocks, np.column_stack((a, b, a2, b2))) / blocks.size
    for stat, samples, series in (
        ("rmse", np.sqrt(sums[:, 2]) - np.sqrt(sums[:, 3]), a2 - b2),
        ("mean", sums[:, 0] - sums[:, 1], a - b),
    ):
        value = out[f"{stat}_diff"]
        sd = spread(samples) * math.sqrt(variance_ratio(series, blocks.length))
        out[f"{stat}_diff_lo"], out[f"{stat}_diff_hi"] = interval(value, sd, level, blocks.dof)
        out[f"{stat}_p"] = p_value(value, sd, blocks.dof)
    return out


def comparison_frame(rows: list[dict[str, object]]) -> pd.DataFrame:
    """``comparisons.csv`` from rows of :data:`COMPARISON_COLUMNS`."""
    out = pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))
    out["n"] = out["n"].astype(np.int64)
    out["block"] = out["block"].astype("Int64")
    return out
