"""Known answers of the intervals and paired comparisons through `coopproc run` / `report`
(issue 33): on the simulated paper experiment (10 min, NLOS on A-B and B-C) DI-Based's
RMSE is significantly below Observed's on the NLOS pairs; the intervals hold the point
figures and are the ones `report` recomputes from ranges.csv (seeded)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.report.formats import SIGNIFICANT_MARK
from coopproc.report.metrics import distance_metrics
from tests.e2e.conftest import E2ERun


def test_di_is_significantly_better_on_nlos_pairs(e2e_runs: Callable[[str, int], E2ERun]) -> None:
    run = e2e_runs("paper-experiment", 0)
    compared = pd.read_csv(run.out / "comparisons.csv")
    nlos_pairs = sorted(set(run.truth_events["pair"]))
    assert nlos_pairs == ["A-B", "B-C"]
    for pair in nlos_pairs:
        row = compared[
            (compared["kind"] == "pair")
            & (compared["group"] == pair)
            & (compared["method"] == "di")
            & (compared["baseline"] == "observed")
        ].iloc[0]
        assert row["rmse_p"] < 0.05 and row["rmse_diff_hi"] < 0, row.to_dict()
        diff = run.metric(pair, "di", "rmse") - run.metric(pair, "observed", "rmse")
        assert row["rmse_diff"] == np.float64(round(diff, 6)) or abs(row["rmse_diff"] - diff) < 2e-6
        assert row["block"] >= 2  # the NLOS events make the errors correlated
    # DI against RN is compared too, and the fused positions of A and C against Observed's
    assert ((compared["method"] == "di") & (compared["baseline"] == "rn")).sum() == 6
    fused = compared[(compared["kind"] == "platform") & (compared["method"] == "di")]
    assert set(fused["group"]) == {"A", "B", "C"}


def test_intervals_hold_the_figures_and_are_reproducible(
    e2e_runs: Callable[[str, int], E2ERun],
) -> None:
    run = e2e_runs("paper-experiment", 0)
    m = run.metrics
    for stat in ("mean", "rmse", "snr_db", "smoothness"):
        assert (m[f"{stat}_lo"] <= m[stat]).all() and (m[stat] <= m[f"{stat}_hi"]).all(), stat
    # every row has its intervals (A-C's distance barely changes: heavy-tailed steps, the
    # blocks drawn one by one), the smoothness ratio's never below 0 (log scale)
    assert m[[c for c in m.columns if c.endswith(("_lo", "_hi"))]].notna().all().all()
    assert (m["smoothness_lo"] > 0).all()
    p = run.position_metrics
    for stat in ("mean", "rmse", "rms_east", "rms_north", "cep50", "cep95"):
        assert (p[f"{stat}_lo"] <= p[stat] + 1e-9).all() and (p[stat] <= p[f"{stat}_hi"]).all()
    # the existing columns first, unchanged in order (DATA.md: new columns appended)
    assert list(m.columns[:8]) == [
        "pair",
        "method",
        "max",
        "mean",
        "rmse",
        "snr_db",
        "smoothness",
        "n",
    ]
    # recomputed from ranges.csv as `report --ci 0.95` would: the same numbers
    again = distance_metrics(run.ranges, ("observed", "rn", "di"), level=0.95)
    assert np.allclose(again["rmse_lo"], m["rmse_lo"], atol=1e-6, rtol=0)
    assert np.allclose(again["smoothness_hi"], m["smoothness_hi"], atol=1e-6, rtol=0)


def test_report_marks_and_accepts_reversed_pairs(e2e_runs: Callable[[str, int], E2ERun]) -> None:
    run = e2e_runs("paper-experiment", 0)
    runner = CliRunner()
    shown = runner.invoke(main, ["report", str(run.out), "--table", "--pairs", "B-A"])
    assert shown.exit_code == 0, shown.output
    table2 = shown.output.split("Table 3.")[0]
    di = next(line for line in table2.splitlines() if "DI-Based" in line)
    assert SIGNIFICANT_MARK in di and "[" in di
    assert "B-C" not in table2 and "A-B" in table2
    narrow = runner.invoke(main, ["report", str(run.out), "--ci", "0.8", "--significance", "none"])
    assert narrow.exit_code == 0, narrow.output
    assert "80 % confidence interval" in narrow.output and SIGNIFICANT_MARK not in narrow.output
    bad = runner.invoke(main, ["report", str(run.out), "--ci", "95"])
    assert bad.exit_code != 0 and "between 0 and 1" in bad.output
