"""The fusion's own outlier decisions through the CLI (issue 30 item 7): an injected gross
range is rejected in range_weights.csv and scored as a true positive in nlos_scores.csv;
the clean ranges around it keep their full weight."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.names import RANGE_WEIGHTS_COLUMNS

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"


def test_injected_gross_ranges_are_rejected_and_scored(tmp_path: Path) -> None:
    """sample_logs (the simulator's paper-experiment, 600 s) with a 20 m spike on B-C 5 s
    in (the filter still converging) and a 5 m one on the line-of-sight pair A-C."""
    runner = CliRunner()
    gross, out = tmp_path / "g", tmp_path / "out"
    spikes = ["--gross", "B-C", "+5", "20", "--gross", "A-C", "+300", "5"]
    res = runner.invoke(main, ["inject", str(SAMPLE), "-o", str(gross), *spikes])
    assert res.exit_code == 0, res.output
    res = runner.invoke(main, ["run", str(gross), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    injected = pd.read_csv(gross / "injected.csv")
    weights = pd.read_csv(out / "range_weights.csv")
    assert list(weights.columns) == list(RANGE_WEIGHTS_COLUMNS)
    n_ranges = int(pd.read_csv(gross / "ranges.csv")["range"].notna().sum())
    assert (weights.groupby("method").size() == n_ranges).all()  # every range, each method
    observed = weights[weights["method"] == "observed"]
    # the observed fusion rejects the two spikes, and on the NLOS pairs A-B and B-C the
    # simulated NLOS ranges that its dead reckoning (DR noise factor 1/32 by the
    # cross-validation, calibration_dr.py) no longer follows: 0.61-0.77 m, 4.1-5.2 sigma
    rejected = observed[observed["rejected"] == 1]
    spikes = set(zip(injected["pair"], injected["time"].round(3), strict=True))
    assert spikes <= set(zip(rejected["pair"], rejected["time"].round(3), strict=True))
    assert (rejected["gamma"] == 0.0).all()
    assert set(rejected["pair"]) == {"A-B", "A-C", "B-C"}
    assert (rejected[rejected["pair"] == "A-C"]["time"].round(3) == 108300.034).all()
    # the residual judged is the spike, far beyond k1 = 4 (measured 19.93 m / 132.9 and
    # 4.94 m / 33.0); the NLOS ones are beyond k1 and under 1 m
    spike = rejected[rejected["standardized"].abs() > 10.0].set_index("pair")["innovation"]
    assert len(spike) == 2
    assert abs(spike["B-C"] - 20.0) < 0.3 and abs(spike["A-C"] - 5.0) < 0.3
    nlos = rejected[rejected["standardized"].abs() <= 10.0]
    assert (nlos["standardized"].abs() > 4.0).all() and (nlos["innovation"].abs() < 1.0).all()
    for pair, t in zip(injected["pair"], injected["time"], strict=True):
        mine = observed[observed["pair"] == pair]
        near = mine[(np.abs(mine["time"] - t) < 3.0) & (np.abs(mine["time"] - t) > 1e-6)]
        assert len(near) >= 3 and (near["gamma"] == 1.0).all()  # the clean ones either side
    scores = pd.read_csv(out / "nlos_scores.csv").set_index(["pair", "method"])
    # A-C is line of sight: its one outlier is the spike, down-weighted and rejected
    ac = scores.loc[("A-C", "fusion:observed")]
    assert (ac["nlos_true"], ac["detected"], ac["tp"], ac["fp"], ac["fn"]) == (1, 1, 1, 0, 0)
    assert ac["events"] == 1 and ac["precision"] == 1.0 and ac["recall"] == 1.0
    bc = scores.loc[("B-C", "fusion:observed")]
    # the spike and the NLOS epochs, none clean (measured 8 events, recall 0.625)
    assert bc["events"] >= 2 and bc["tp"] >= 10 and bc["fp"] == 0
    facts = json.loads((out / "run.json").read_text())["summary"]["fusion_outliers"]
    assert list(facts) == ["observed", "rn", "di"]
    # every rejection is a true outlier (measured 18 of 18)
    assert facts["observed"]["rejected"] >= 10
    assert facts["observed"]["rejected_outliers"] == facts["observed"]["rejected"]
    line = next(x for x in res.output.splitlines() if x.startswith("fusion down-weighted"))
    n = facts["observed"]["rejected"]
    assert f"({n} rejected) in observed" in line and f" ({n}) of the " in line
