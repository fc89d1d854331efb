"""Position statistics pooled over many sessions (``coopproc batch``:
``ROOT/pooled_position_metrics.csv``).

The rule: **pool the errors, not the statistics**. Every evaluation epoch of every session
(:func:`coopproc.report.evaluation.matched_tracks`: the epochs with an ``error_h`` and a
reference row; no alignment) counts once, so a long session weighs more than a short one
and the pooled RMSE is ``sqrt(sum over sessions of sum h_i^2 / total n)`` =
``sqrt(sum_k n_k rmse_k^2 / sum_k n_k)``, never the mean of the sessions' RMSEs. Every
other statistic is taken over the pooled errors the same way (the mean of all errors, the
percentiles of all errors, the largest error).

One row per platform id and method, pooled over the sessions that have that platform,
then one row per method pooled over every platform of every session (``platform`` =
``*``, not a valid platform id). Columns: ``platform, method, sessions, n, max, mean,
rmse, rms_east, rms_north, cep50, cep95`` as in ``position_metrics.csv`` (horizontal
error h = |(d_e, d_n)|, recomputed from the positions: the ``error_h`` of the CSV to its
1 um), then ``rms_up`` and ``rmse_3d``, then the 95 % intervals ``mean_lo, mean_hi,
rmse_lo, rmse_hi`` of a two-stage bootstrap that resamples sessions, and blocks within
each (:mod:`coopproc.report.pooled_stats`), which also gives ``pooled_comparisons.csv``
(:func:`pooled_tables`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.evaluation import matched_tracks
from coopproc.report.methods import method_order
from coopproc.report.pooled_stats import (
    POOLED_INTERVAL_COLUMNS,
    PooledSums,
    pooled_comparisons,
    pooled_intervals,
    track_sums,
)

__all__ = ["ALL_PLATFORMS", "POOLED_COLUMNS", "pooled_position_metrics", "pooled_tables"]

#: ``platform`` of the rows pooled over every platform.
ALL_PLATFORMS = "*"
POOLED_COLUMNS: tuple[str, ...] = (
    "platform",
    "method",
    "sessions",
    "n",
    "max",
    "mean",
    "rmse",
    "rms_east",
    "rms_north",
    "cep50",
    "cep95",
    "rms_up",
    "rmse_3d",
    *POOLED_INTERVAL_COLUMNS,
)


def _stats(d: FloatArray) -> dict[str, float]:
    if not d.shape[0]:
        return dict.fromkeys(POOLED_COLUMNS[4:-4], float("nan"))
    h = np.hypot(d[:, 0], d[:, 1])
    rms = np.sqrt(np.mean(d * d, axis=0))
    return {
        "max": float(np.max(h)),
        "mean": float(np.mean(h)),
        "rmse": float(np.sqrt(np.mean(h * h))),
        "rms_east": float(rms[0]),
        "rms_north": float(rms[1]),
        "cep50": float(np.percentile(h, 50)),
        "cep95": float(np.percentile(h, 95)),
        "rms_up": float(rms[2]),
        "rmse_3d": float(np.sqrt(np.mean(np.sum(d * d, axis=1)))),
    }


def pooled_position_metrics(
    positions: Mapping[str, pd.DataFrame] | Iterable[tuple[str, pd.DataFrame]],
) -> pd.DataFrame:
    """The pooled table (module doc) of the ``positions.csv`` tables of many sessions, by
    session name (the order of the mapping is the order errors are stacked in).

    ``positions`` may be an iterable of (session, table) read one at a time: only each
    table's errors are kept (3 floats per epoch, and the time and h of each track for the
    comparisons), not the tables."""
    return pooled_tables(positions)[0]


def pooled_tables(
    positions: Mapping[str, pd.DataFrame] | Iterable[tuple[str, pd.DataFrame]],
    level: float = DEFAULT_LEVEL,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``pooled_position_metrics.csv`` and ``pooled_comparisons.csv`` (module doc) in one
    pass over the sessions' tables; intervals at ``level``."""
    errors: dict[tuple[str, str], list[FloatArray]] = {}
    sessions: dict[tuple[str, str], set[str]] = {}
    pools: dict[tuple[str, str], PooledSums] = {}
    tracks: dict[str, dict[str, dict[str, tuple[FloatArray, FloatArray]]]] = {}
    methods: list[str] = []
    pairs = positions.items() if isinstance(positions, Mapping) else positions
    for session, table in pairs:
        for platform, method, t, est, ref in matched_tracks(table):
            d = est - ref  # one array, listed under the platform and under "*"
            h = np.hypot(d[:, 0], d[:, 1])
            if h.shape[0] >= 2:
                sums, dof = track_sums([h], (session, platform, method))
                sample = np.array([h.sum(), (h * h).sum(), float(h.shape[0])])
                tracks.setdefault(session, {}).setdefault(platform, {})[method] = (t, h)
            for key in ((platform, method), (ALL_PLATFORMS, method)):
                errors.setdefault(key, []).append(d)
                if est.shape[0]:  # a session counts where it has epochs
                    sessions.setdefault(key, set()).add(session)
                if h.shape[0] >= 2:
                    pools.setdefault(key, PooledSums()).add(session, sums, sample, dof)
            methods.append(method)
    order = method_order(methods, ("nav",))  # then in the order the sessions list them
    platforms = sorted({p for p, _ in errors if p != ALL_PLATFORMS})
    rows = []
    for platform in [*platforms, ALL_PLATFORMS]:
        for method in order:
            if (platform, method) not in errors:
                continue
            d = np.concatenate(errors[(platform, method)], axis=0)
            row: dict[str, object] = {
                "platform": platform,
                "method": method,
                "sessions": len(sessions.get((platform, method), ())),
                "n": int(d.shape[0]),
            }
            row.update(_stats(d))
            pool = pools.get((platform, method), PooledSums())
            row.update(pooled_intervals(pool, (platform, method), level))
            rows.append(row)
    out = pd.DataFrame(rows, columns=list(POOLED_COLUMNS))
    out[["sessions", "n"]] = out[["sessions", "n"]].astype(np.int64)
    return out, pooled_comparisons(tracks, order, level)
