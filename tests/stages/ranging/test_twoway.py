"""The two runs combined (issue 30.5, stages/ranging/twoway.py): each run is trusted at its
own detection of an event the other run confirms, when the ranges less the summed
increments step there; through the session files and their readers, the navigation
standing in for the cooperative solution (as in test_rn_sim.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.io.session import read_session
from coopproc.sim import simulate, write_simulation
from coopproc.stages.ranging.stage import RangingConfig, RangingOutput, run_ranging


def _run(root: Path, scenario: str, seed: int) -> tuple[RangingOutput, pd.DataFrame]:
    write_simulation(simulate(scenario, seed=seed), root, force=True)
    session = read_session(root)
    return run_ranging(session, session.nav, RangingConfig()), pd.read_csv(
        root / "truth" / "nlos_events.csv"
    )


def _ratio(ranges: pd.DataFrame, pair: str, method: str) -> float:
    g = ranges[ranges["pair"] == pair]
    err = g[[method, "observed"]].sub(g["reference"], axis=0)
    return float(np.sqrt((err[method] ** 2).mean() / (err["observed"] ** 2).mean()))


@pytest.mark.parametrize(
    ("scenario", "seed", "method", "bound"),
    [
        # the forward DI run ended a 25 s event after 5 s where the excess dipped to
        # 0.30 m; the backward run held it to the end: 0.82 x the observed before, 0.54 now
        ("noisy-leader", 3, "di", 0.65),
        # the RN runs each caught a different part of the event: 0.79 x before, 0.51 now
        ("paper-experiment", 13, "rn", 0.62),
    ],
)
def test_a_run_is_trusted_where_it_detects(
    tmp_path: Path, scenario: str, seed: int, method: str, bound: float
) -> None:
    out, _ = _run(tmp_path / "s", scenario, seed)
    assert _ratio(out.ranges, "A-B", method) <= bound


def test_a_false_forward_hold_is_not_extended_over_line_of_sight(tmp_path: Path) -> None:
    # paper-experiment seed 8: the forward RN run took a 0.34 m residual after a -0.30 m
    # outlier (108080 s) for an onset and held it 40 s into the real event (108120-108145);
    # the ranges step at the event's onset, not at 108080, so nothing is added there
    # (extended without the step test: RN A-B 0.87 x the observed against 0.49)
    out, truth = _run(tmp_path / "s", "paper-experiment", 8)
    assert out.rn_nlos is not None
    ab = out.ranges["pair"].eq("A-B").to_numpy()
    flagged = out.ranges.loc[ab & (out.rn_nlos[0] == 1), "time"]
    inside = np.zeros(len(flagged), dtype=bool)
    for _, t in truth[truth["pair"] == "A-B"].iterrows():
        inside |= ((flagged >= t["start"] - 1.0) & (flagged <= t["end"] + 1.0)).to_numpy()
    assert np.count_nonzero(~inside) <= 1
    assert _ratio(out.ranges, "A-B", "rn") <= 0.6
