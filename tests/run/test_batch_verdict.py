"""Pooled intervals that resample sessions and blocks, and the one-line verdict per method
pair of ``coopproc batch`` (``pooled_comparisons.csv``; report/pooled_stats.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from coopproc.io.outdir import write_csv
from coopproc.report.metrics import position_metrics
from coopproc.report.pooled import pooled_tables
from coopproc.report.pooled_stats import verdict
from coopproc.run.batch_root import POOLED, POOLED_COMPARISONS, BatchEntry, write_listing


def _session(seed: int, scale: dict[str, float], n: int = 300) -> pd.DataFrame:
    """Platforms A and B; each method's east/north errors AR(1) (rho 0.9) times its scale."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    rows = []
    for platform in "AB":
        ref = np.column_stack([t, 0.3 * t, np.zeros(n)])
        common = lfilter([1.0], [1.0, -0.9], rng.standard_normal((2, n)), axis=1) * 0.44
        for method, s in (("reference", 0.0), *scale.items()):
            own = lfilter([1.0], [1.0, -0.9], rng.standard_normal((2, n)), axis=1) * 0.44
            d = s * (0.7 * common + 0.7 * own)
            xyz = ref + np.column_stack([d[0], d[1], np.zeros(n)])
            h = np.hypot(d[0], d[1]) if method != "reference" else np.full(n, np.nan)
            rows.append(
                pd.DataFrame(
                    {
                        "time": t,
                        "platform": platform,
                        "method": method,
                        "east": xyz[:, 0],
                        "north": xyz[:, 1],
                        "up": xyz[:, 2],
                        "error_h": h,
                    }
                )
            )
    return pd.concat(rows, ignore_index=True)


def test_verdict_counts_sessions_and_pools_the_change() -> None:
    # DI 30 % smaller than Observed on 14 sessions, 30 % larger on one
    sessions = {
        f"s{k:02d}": _session(k, {"observed": 0.1, "di": 0.07 if k != 3 else 0.13})
        for k in range(15)
    }
    pooled, compared = pooled_tables(sessions)
    row = compared[(compared["method"] == "di") & (compared["baseline"] == "observed")].iloc[0]
    assert (row["sessions"], row["better"]) == (15, 14)
    assert row["change_lo"] < row["change_pct"] < row["change_hi"] < 0 and row["p"] < 0.05
    line = verdict(row.to_dict())
    assert line.startswith("DI-Based better than Observed on 14 of 15 sessions, pooled RMSE -")
    assert line.endswith("(p < 0.05)")
    # the pooled intervals hold the pooled figures
    every = pooled[(pooled["platform"] == "*") & (pooled["method"] == "di")].iloc[0]
    one = pooled[(pooled["platform"] == "A") & (pooled["method"] == "di")].iloc[0]
    for r in (every, one):
        assert r["rmse_lo"] < r["rmse"] < r["rmse_hi"] and r["mean_lo"] < r["mean"] < r["mean_hi"]
    # the odd session (DI 0.13) counts: resampling sessions widens the interval beyond
    # what the blocks alone give (the same sessions without it)
    alike = {k: v for k, v in sessions.items() if k != "s03"}
    calm = pooled_tables(alike)[0]
    calm = calm[(calm["platform"] == "*") & (calm["method"] == "di")].iloc[0]
    assert every["rmse_hi"] - every["rmse_lo"] > 1.5 * (calm["rmse_hi"] - calm["rmse_lo"])


def test_equal_methods_get_no_verdict_of_significance(tmp_path: Path) -> None:
    sessions = {f"s{k}": _session(40 + k, {"observed": 0.1, "di": 0.1}) for k in range(4)}
    entries = []
    for name, positions in sessions.items():
        out = tmp_path / name
        out.mkdir()
        write_csv(positions, out / "positions.csv")
        write_csv(position_metrics(positions), out / "position_metrics.csv")
        write_csv(pd.DataFrame({"pair": ["A-B"], "method": ["di"]}), out / "metrics.csv")
        entries.append(BatchEntry(str(out), name, True, "", "processed", "2026-01-01T00:00:00"))
    write_listing(tmp_path, entries)
    assert (tmp_path / POOLED).is_file()
    compared = pd.read_csv(tmp_path / POOLED_COMPARISONS)
    row = compared.iloc[0]
    assert row["p"] > 0.05 and row["change_lo"] < 0 < row["change_hi"]
    assert "not significant" in verdict(row.to_dict())
    write_listing(tmp_path, [])  # no ok session: both pooled files go
    assert not (tmp_path / POOLED_COMPARISONS).exists()
