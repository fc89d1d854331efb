"""Issue 4 acceptance: paper 000's ranging error processing against simulated truth,
through real files and `coopproc run` (simulate -> write -> read -> run -> read CSVs)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
import pytest

from tests.e2e.conftest import E2ERun


def _matching_event(events: pd.DataFrame, pair: str, method: str, start: float, end: float):
    """The first detected event of ``method`` on ``pair`` that overlaps [start, end]."""
    rows = events[(events["pair"] == pair) & (events["method"] == method)]
    rows = rows[(rows["start"] <= end) & (rows["end"] >= start)]
    return None if rows.empty else rows.iloc[0]


def _estimate_errors(run: E2ERun, method: str) -> list[float]:
    """Relative error of each truth event's estimate, |est - realized| / realized."""
    errors = []
    for ev in run.truth_events.itertuples():
        found = _matching_event(run.events, ev.pair, method, ev.start, ev.end)
        assert found is not None, f"{method}: event {ev.pair} {ev.start}-{ev.end} not detected"
        errors.append(abs(found["estimate"] - ev.realized_mean) / ev.realized_mean)
    return errors


def _los_mask(run: E2ERun) -> np.ndarray:
    """Range epochs outside every true NLOS event (with 1 s margin for the rate)."""
    r = run.ranges
    nlos = np.zeros(len(r), dtype=bool)
    for ev in run.truth_events.itertuples():
        nlos |= (r["pair"] == ev.pair).to_numpy() & (
            (r["time"] >= ev.start - 1.0) & (r["time"] <= ev.end + 1.0)
        ).to_numpy()
    return ~nlos


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_table1_estimates(e2e_runs: Callable[[str, int], E2ERun], seed: int) -> None:
    """Paper 000 Table 1: three simulated NLOS at 10 Hz, M = 3 s."""
    run = e2e_runs("paper-table1", seed)
    di = _estimate_errors(run, "di")
    rn = _estimate_errors(run, "rn")
    print(f"\nTable 1 (paper-table1, seed {seed}): relative NLOS estimate error")
    print("event  realized(m)   RN-Based   DI-Based")
    for i, ev in enumerate(run.truth_events.itertuples()):
        print(f"NLOS{i + 1}  {ev.realized_mean:9.4f}   {100 * rn[i]:7.2f}%   {100 * di[i]:7.2f}%")
    print(f"mean              {100 * np.mean(rn):7.2f}%   {100 * np.mean(di):7.2f}%")
    assert len(di) == 3
    assert np.mean(di) <= 0.08
    assert max(di) <= 0.15
    assert np.mean(rn) > np.mean(di)


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_experiment_detection(e2e_runs: Callable[[str, int], E2ERun], seed: int) -> None:
    """Every NLOS event detected, estimates within 15 % on average, <= 1 % false flags."""
    run = e2e_runs("paper-experiment", seed)
    errors = _estimate_errors(run, "di")
    assert len(errors) == 4
    # measured (10 min, seeds 0-9): 0.107 / 0.155 / 0.151 / 0.203 / 0.048 / ... mean 0.126
    # (0.121 with the CP and DR DI of the navigation as recorded; seed 1 0.147 then)
    assert np.mean(errors) <= 0.16
    los = _los_mask(run)
    false_rate = run.ranges["nlos_flag"].to_numpy()[los].mean()
    assert false_rate <= 0.01, f"false NLOS flags on {100 * false_rate:.2f}% of LOS epochs"


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_experiment_table2(e2e_runs: Callable[[str, int], E2ERun], seed: int) -> None:
    """Table 2: DI-Based cuts RMSE and max on NLOS pairs, and noise on the LOS pair."""
    run = e2e_runs("paper-experiment", seed)
    nlos_pairs = set(run.truth_events["pair"])
    for pair in sorted(set(run.metrics["pair"])):
        obs_rmse, di_rmse = run.metric(pair, "observed", "rmse"), run.metric(pair, "di", "rmse")
        obs_max, di_max = run.metric(pair, "observed", "max"), run.metric(pair, "di", "max")
        if pair in nlos_pairs:
            assert di_rmse <= 0.5 * obs_rmse, (pair, di_rmse, obs_rmse)
            assert di_max <= 0.4 * obs_max, (pair, di_max, obs_max)
            assert di_rmse < run.metric(pair, "rn", "rmse"), pair
        else:
            assert di_rmse <= 0.7 * obs_rmse, (pair, di_rmse, obs_rmse)
            assert di_max <= 0.7 * obs_max, (pair, di_max, obs_max)
            di_s = run.metric(pair, "di", "smoothness")
            obs_s = run.metric(pair, "observed", "smoothness")
            assert abs(di_s - 1.0) < abs(obs_s - 1.0), (pair, di_s, obs_s)


def test_scores_say_the_filters_smoothed_with_the_di(
    e2e_runs: Callable[[str, int], E2ERun],
) -> None:
    """paper-experiment's dead reckoning smooths every pair in every window: nlos_scores.csv
    says mode di, no ranges-only epochs (tuc's say ranges: test_e2e_trust.py); run.json
    says the CP DI came from all ranges (paper 000's CP, the default)."""
    run = e2e_runs("paper-experiment", 0)
    scores = pd.read_csv(run.out / "nlos_scores.csv", keep_default_na=False)
    mine = scores[scores["method"].isin(["di", "rn"])]
    assert len(mine) == 6 and (mine["mode"] == "di").all()
    assert (mine["ranges_only_fraction"].astype(float) == 0.0).all()
    info = pd.read_json(run.out / "run.json", typ="series")
    sources = {p: m["di"]["cp_source"] for p, m in info["calibration"]["ranging"].items()}
    assert set(sources.values()) == {"all ranges"}  # [fusion] cp_folds = 0, the default
