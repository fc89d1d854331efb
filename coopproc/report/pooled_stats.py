"""Intervals and verdicts of statistics pooled over many sessions (``coopproc batch``).

A **two-stage bootstrap**: each of the B resamples draws the sessions with replacement
(sessions are the independent units: their platforms share a day, a site, a clock), and
within each drawn session its own block resample (:mod:`coopproc.report.bootstrap`, the
blocks of each platform's track, length from its errors). A session's resample is kept as
sums (``sum h``, ``sum h^2``, epochs), so a pooled resample is a sum of S rows, and
the pooled statistics are those of :mod:`coopproc.report.pooled` (errors pooled, not
statistics): ``mean = sum h / N``, ``rmse = sqrt(sum h^2 / N)``. The interval is
``T +- t sd`` with ``S - 1`` degrees of freedom (one session: the blocks' own, as a
single run's interval).

**Verdicts** (``pooled_comparisons.csv``, one line per method pair in ``batch``'s
output): for each method against ``observed`` and ``di`` against ``rn``, over the epochs
both have (same session, platform and time), on how many sessions the method's RMSE of h
is the smaller, and the pooled RMSE change ``100 (rmse_m / rmse_b - 1)`` % with its
interval and p-value from the same two-stage resamples drawn for both methods (paired).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.bootstrap import (
    DEFAULT_LEVEL,
    DEFAULT_RESAMPLES,
    block_length,
    draw_blocks,
    generator,
    interval,
    p_value,
    resampled_sums,
    spread,
)
from coopproc.report.intervals import comparison_pairs
from coopproc.report.table_specs import method_label

__all__ = [
    "POOLED_COMPARISON_COLUMNS",
    "POOLED_INTERVAL_COLUMNS",
    "PooledSums",
    "pooled_comparisons",
    "pooled_intervals",
    "verdict",
]

#: Columns pooled_position_metrics.csv appends.
POOLED_INTERVAL_COLUMNS: tuple[str, ...] = ("mean_lo", "mean_hi", "rmse_lo", "rmse_hi")
#: Columns of ``pooled_comparisons.csv``.
POOLED_COMPARISON_COLUMNS: tuple[str, ...] = (
    "method",
    "baseline",
    "sessions",
    "better",
    "n",
    "rmse",
    "rmse_baseline",
    "change_pct",
    "change_lo",
    "change_hi",
    "p",
)


def track_sums(series: Sequence[FloatArray], names: Sequence[str]) -> tuple[FloatArray, float]:
    """B resampled ``(sum of each series' column..., epochs)`` of equally long series
    resampled with the same blocks (length: the longest of theirs), and the blocks'
    degrees of freedom; columns: ``sum x``, ``sum x^2`` of each series, then epochs."""
    n = int(series[0].shape[0])
    length = max(block_length(x) for x in series)
    blocks = draw_blocks(n, length, DEFAULT_RESAMPLES, generator(*names))
    cols = [c for x in series for c in (x, x * x)]
    sums = resampled_sums(blocks, np.column_stack(cols))
    return np.column_stack((sums, np.full(sums.shape[0], float(blocks.size)))), blocks.dof


@dataclass
class PooledSums:
    """Per session, the B resampled sums of one pooled row (added up over its platforms),
    the sample's own sums, and the smallest blocks' degrees of freedom."""

    resampled: dict[str, FloatArray] = field(default_factory=dict)
    sample: dict[str, FloatArray] = field(default_factory=dict)
    dof: float = math.inf

    def add(self, session: str, sums: FloatArray, sample: FloatArray, dof: float) -> None:
        if session in self.resampled:
            self.resampled[session] = self.resampled[session] + sums
            self.sample[session] = self.sample[session] + sample
        else:
            self.resampled[session], self.sample[session] = sums, sample
        self.dof = min(self.dof, dof)

    def pooled(self, names: Sequence[str]) -> tuple[FloatArray, FloatArray, float]:
        """(B, m) two-stage resampled pooled sums, the sample's (m,), degrees of freedom."""
        sessions = sorted(self.resampled)
        stack = np.stack([self.resampled[s] for s in sessions])  # (S, B, m)
        count, resamples = stack.shape[0], stack.shape[1]
        if count == 1:
            return stack[0], self.sample[sessions[0]], self.dof
        draws = generator("sessions", *names).integers(0, count, size=(resamples, count))
        picked = stack[draws, np.arange(resamples)[:, None]]  # (B, S, m)
        total = np.sum([self.sample[s] for s in sessions], axis=0)
        return picked.sum(axis=1), total, float(count - 1)


def pooled_intervals(pool: PooledSums, names: Sequence[str], level: float) -> dict[str, float]:
    """``mean_lo .. rmse_hi`` of one pooled row from its sums (h, h^2, epochs)."""
    if not pool.resampled:
        return dict.fromkeys(POOLED_INTERVAL_COLUMNS, float("nan"))
    star, sample, dof = pool.pooled(names)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = star[:, 0] / star[:, 2]
        rmse = np.sqrt(star[:, 1] / star[:, 2])
    out: dict[str, float] = {}
    values = (sample[0] / sample[2], math.sqrt(sample[1] / sample[2]))
    for stat, value, samples in zip(("mean", "rmse"), values, (mean, rmse), strict=True):
        out[f"{stat}_lo"], out[f"{stat}_hi"] = interval(value, spread(samples), level, dof)
    return out


def pooled_comparisons(
    tracks: Mapping[str, Mapping[str, Mapping[str, tuple[FloatArray, FloatArray]]]],
    methods: Sequence[str],
    level: float = DEFAULT_LEVEL,
) -> pd.DataFrame:
    """``pooled_comparisons.csv`` from ``tracks[session][platform][method] = (time, h)``
    (module doc); ``methods`` in the table's order."""
    rows = []
    for method, baseline in comparison_pairs(methods):
        pool = PooledSums()
        better = 0
        sessions = 0
        for session, platforms in tracks.items():
            sq = np.zeros(2)
            for platform, by_method in platforms.items():
                if method not in by_method or baseline not in by_method:
                    continue
                (t_a, h_a), (t_b, h_b) = by_method[method], by_method[baseline]
                _t, ia, ib = np.intersect1d(t_a, t_b, return_indices=True)
                a, b = h_a[ia], h_b[ib]
                if a.shape[0] < 2:
                    continue
                names = (session, platform, method, baseline)
                sums, dof = track_sums([a, b], names)
                sample = np.array([a.sum(), (a * a).sum(), b.sum(), (b * b).sum(), a.size])
                pool.add(session, sums, sample, dof)
                sq += sample[[1, 3]]
            if sq[1] > 0:
                sessions += 1
                better += int(sq[0] < sq[1])
        row: dict[str, object] = {"method": method, "baseline": baseline}
        row.update(sessions=sessions, better=better)
        if not pool.resampled:
            rows.append(row)
            continue
        star, sample, dof = pool.pooled(("compare", method, baseline))
        n = sample[4]
        rmse_a, rmse_b = math.sqrt(sample[1] / n), math.sqrt(sample[3] / n)
        with np.errstate(divide="ignore", invalid="ignore"):
            change = 100.0 * (np.sqrt(star[:, 1] / star[:, 3]) - 1.0)
        value = 100.0 * (rmse_a / rmse_b - 1.0) if rmse_b > 0 else float("nan")
        sd = spread(change)
        lo, hi = interval(value, sd, level, dof)
        row.update(n=int(n), rmse=rmse_a, rmse_baseline=rmse_b, change_pct=value)
        row.update(change_lo=lo, change_hi=hi, p=p_value(value, sd, dof))
        rows.append(row)
    out = pd.DataFrame(rows, columns=list(POOLED_COMPARISON_COLUMNS))
    out[["sessions", "better"]] = out[["sessions", "better"]].astype(np.int64)
    out["n"] = out["n"].astype("Int64")
    return out


def verdict(row: Mapping[str, object], alpha: float = 0.05) -> str:
    """One line for a row of ``pooled_comparisons.csv``, e.g. "DI-Based better than
    Observed on 14 of 15 sessions, pooled RMSE -37.0 % [-42.1, -31.0] (p < 0.05)"."""
    method, baseline = method_label(str(row["method"])), method_label(str(row["baseline"]))
    head = f"{method} better than {baseline} on {row['better']} of {row['sessions']} sessions"
    change = float(row["change_pct"])  # type: ignore[arg-type]
    if not math.isfinite(change):
        return head
    lo, hi = float(row["change_lo"]), float(row["change_hi"])  # type: ignore[arg-type]
    p = float(row["p"])  # type: ignore[arg-type]
    mark = f"p < {alpha:g}" if p < alpha else f"not significant, p = {p:.2f}"
    return f"{head}, pooled RMSE {change:+.1f} % [{lo:+.1f}, {hi:+.1f}] ({mark})"
