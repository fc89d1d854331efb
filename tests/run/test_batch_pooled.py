"""``ROOT/pooled_position_metrics.csv`` of ``coopproc batch``: the errors of every session
pooled, never a mean of per-session statistics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.io.outdir import write_csv
from coopproc.report.metrics import position_metrics
from coopproc.report.pooled import POOLED_COLUMNS, pooled_position_metrics
from coopproc.run.batch_root import POOLED, BatchEntry, write_listing


def _positions(n: int, error: float, platforms: str = "AB", seed: int = 0) -> pd.DataFrame:
    """n epochs per platform; method ``di`` off the reference by ``error`` (random bearing)."""
    rng = np.random.default_rng(seed)
    rows = []
    for platform in platforms:
        t = np.arange(n, dtype=float)
        ref = np.column_stack([t, 0.5 * t, np.zeros(n)])
        bearing = rng.uniform(0, 2 * np.pi, n)
        d = error * np.column_stack([np.cos(bearing), np.sin(bearing), np.full(n, 0.5)])
        for method, xyz, h in (("reference", ref, np.nan), ("di", ref + d, error)):
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


def test_pooled_rmse_weighs_every_epoch_once() -> None:
    short, long = _positions(10, 1.0), _positions(90, 0.1, platforms="A", seed=1)
    pooled = pooled_position_metrics({"s1": short, "s2": long}).set_index(["platform", "method"])
    assert list(pooled.reset_index().columns) == list(POOLED_COLUMNS)
    assert list(pooled.index) == [("A", "di"), ("B", "di"), ("*", "di")]
    a = pooled.loc[("A", "di")]
    assert (a["sessions"], a["n"]) == (2, 100)
    # sqrt((10 * 1.0^2 + 90 * 0.1^2) / 100), not the mean of the sessions' RMSEs (0.55)
    assert a["rmse"] == pytest.approx(np.sqrt((10 * 1.0 + 90 * 0.01) / 100), rel=1e-12)
    assert a["mean"] == pytest.approx((10 * 1.0 + 90 * 0.1) / 100, rel=1e-12)
    assert a["max"] == pytest.approx(1.0) and a["rms_up"] == pytest.approx(a["rmse"] / 2)
    assert a["rmse_3d"] == pytest.approx(np.sqrt(1.25) * a["rmse"], rel=1e-12)
    assert a["cep50"] == pytest.approx(0.1) and a["cep95"] == pytest.approx(1.0)
    every = pooled.loc[("*", "di")]  # all platforms of all sessions: 10 + 10 + 90 epochs
    assert (every["sessions"], every["n"]) == (2, 110)
    assert every["rmse"] == pytest.approx(np.sqrt((20 * 1.0 + 90 * 0.01) / 110), rel=1e-12)
    assert pooled.loc[("B", "di"), "sessions"] == 1


def test_batch_root_gets_the_pooled_table(tmp_path: Path) -> None:
    sessions = {"s1": _positions(10, 1.0), "s2": _positions(30, 0.2, seed=3)}
    entries = []
    for name, positions in sessions.items():
        out = tmp_path / name
        out.mkdir()
        write_csv(positions, out / "positions.csv")
        write_csv(position_metrics(positions), out / "position_metrics.csv")
        write_csv(pd.DataFrame({"pair": ["A-B"], "method": ["di"]}), out / "metrics.csv")
        entries.append(BatchEntry(str(out), name, True, "", "processed", "2026-01-01T00:00:00"))
    failed = BatchEntry("/gone", "s3", False, "error", "failed", "2026-01-01T00:00:00")
    write_listing(tmp_path, [*entries, failed])
    pooled = pd.read_csv(tmp_path / POOLED, keep_default_na=False)
    table3 = pd.concat(position_metrics(p) for p in sessions.values())
    # the rule, from the sessions' own Table 3: sqrt(sum n_k rmse_k^2 / sum n_k)
    expected = np.sqrt((table3["n"] * table3["rmse"] ** 2).sum() / table3["n"].sum())
    row = pooled[pooled["platform"] == "*"].iloc[0]
    assert (row["method"], row["sessions"], row["n"]) == ("di", 2, 80)
    assert row["rmse"] == pytest.approx(expected, abs=1e-6)
    write_listing(tmp_path, [failed])  # no session ok: no pooled table
    assert not (tmp_path / POOLED).exists()
