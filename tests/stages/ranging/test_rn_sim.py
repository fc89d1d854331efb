"""RN-Based on the simulator's paper sessions, through the session files and their readers
(issue 30.5): it detects >= 90 % of the simulated NLOS events and estimates them within
15 % on average.

The distance filter of RN does not use the cooperative solution, so the navigation stands
in for it here (the DI method runs too, on it; these tests do not judge DI): a few seconds
per session instead of a full ``coopproc run``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.io.session import read_session
from coopproc.sim import simulate, write_simulation
from coopproc.stages.ranging.stage import RangingConfig, run_ranging


def _rn_events(root: Path, scenario: str, seed: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(RN events, truth events) of a simulated session written to and read from files."""
    write_simulation(simulate(scenario, seed=seed), root, force=True)
    session = read_session(root)
    out = run_ranging(session, session.nav, RangingConfig())
    events = out.nlos_events[out.nlos_events["method"] == "rn"]
    return events, pd.read_csv(root / "truth" / "nlos_events.csv")


def _scores(events: pd.DataFrame, truth: pd.DataFrame) -> tuple[int, list[float], int]:
    """(truth events detected, relative estimate errors of those, RN events matching no
    truth event). A truth event's estimate is the epoch-weighted one of the RN events
    overlapping it."""
    found, errors, used = 0, [], set()
    for _, t in truth.iterrows():
        hit = events[
            (events["pair"] == t["pair"])
            & (events["start"] <= t["end"] + 0.5)
            & (events["end"] >= t["start"] - 0.5)
        ]
        if hit.empty:
            continue
        found += 1
        used.update(hit.index)
        estimate = float(np.average(hit["estimate"], weights=hit["epochs"]))
        errors.append(abs(estimate - t["realized_mean"]) / t["realized_mean"])
    return found, errors, len(events) - len(used)


@pytest.mark.parametrize(
    ("scenario", "seeds"),
    [
        ("paper-experiment", (1, 2, 3, 4, 5)),
        ("paper-table1", (0, 1, 2, 3)),
        ("noisy-leader", (0, 1, 2, 3)),
    ],
)
def test_rn_detects_and_estimates_within_15_percent(
    tmp_path: Path, scenario: str, seeds: tuple[int, ...]
) -> None:
    found, errors, false, true = 0, [], 0, 0
    for seed in seeds:
        events, truth = _rn_events(tmp_path / f"s{seed}", scenario, seed)
        f, e, x = _scores(events, truth)
        found, false, true = found + f, false + x, true + len(truth)
        errors.extend(e)
    print(f"\n{scenario}: RN found {found}/{true}, false {false}, mean error {np.mean(errors):.3f}")
    assert found >= 0.9 * true
    assert false == 0
    # the mean over the events (the brief: within 20 %): one single-epoch residual per run
    # has a spread of the NLOS draw's 0.1 m and the range noise's 0.08 m (~25 % of a 0.5 m
    # event), so single events exceed 20 % (paper 000 Table 1: RN 11 / 21 / 13 %). Measured
    # 0.129 / 0.140 / 0.136; with the forward run's estimate alone (before issue 30.5)
    # 0.167 / 0.154 / 0.206, which this bound rejects
    assert np.mean(errors) <= 0.15


def test_rn_hold_ends_with_its_obstruction_at_10_hz(tmp_path: Path) -> None:
    """paper-table1 seed 5: before RN left unused the epoch that breaks a pending end of two
    or more epochs, that noisy epoch restarted the hold with L - eps_hat, which agrees with
    itself, and both runs held one event from the first obstruction (10-20 s) over 30 s of
    line of sight into the second (50-60 s): 290 flagged epochs outside the truth spans, RN's
    A-B RMSE 26 % above the observed."""
    root = tmp_path / "s5"
    write_simulation(simulate("paper-table1", seed=5), root, force=True)
    session = read_session(root)
    out = run_ranging(session, session.nav, RangingConfig())
    assert out.rn_nlos is not None
    truth = pd.read_csv(root / "truth" / "nlos_events.csv")
    ranges = out.ranges
    flagged = ranges.loc[ranges["pair"].eq("A-B").to_numpy() & (out.rn_nlos[0] == 1), "time"]
    inside = np.zeros(len(flagged), dtype=bool)
    for _, t in truth.iterrows():
        inside |= ((flagged >= t["start"]) & (flagged <= t["end"] + 1.0)).to_numpy()
    assert len(flagged) >= 0.9 * truth["epochs"].sum()
    assert np.count_nonzero(~inside) <= 10  # 1 s at 10 Hz
