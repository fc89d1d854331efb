"""`coopproc inject` -> `coopproc run` -> `coopproc report`: the methods scored on injected NLOS.

Paper 000 sec. 4.3 / Table 1 replayed twice: on a simulated session without NLOS of its
own, and (acceptance of issue 14 item 5) on the real TIERS recording, three NLOS events on
line-of-sight pairs (skipped when ``../shared/data`` is absent).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.sim import simulate, write_simulation

TIERS = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real" / "tiers"
#: Paper 000 Table 1: the largest DI-Based estimation error of the three events (NLOS1,
#: 0.45 m estimated as 0.4868 m: 8.17 %).
PAPER_DI_MAX_ERROR_M = 0.0368
#: The estimation time M of eq. (11)-(12) (paper 000 sec. 4.3; `[ranging.nlos] window_s`).
M_S = 3.0


def _cli(*args: str) -> str:
    res = CliRunner().invoke(main, list(args))
    assert res.exit_code == 0, res.output
    return res.output


def _inject_and_run(
    session: Path, tmp: Path, events: list[tuple[str, ...]], seed: int, *run_args: str
) -> Path:
    nlos = [a for ev in events for a in ("--nlos", *ev)]
    _cli("inject", str(session), "-o", str(tmp / "new"), *nlos, "--seed", str(seed))
    _cli("run", str(tmp / "new"), "-o", str(tmp / "out"), "--no-figures", "-q", *run_args)
    return tmp / "out"


def _table(out: Path) -> str:
    """The injected-NLOS table as `coopproc report OUT --table` prints it."""
    text = _cli("report", str(out), "--table")
    table = text[text.index("Injected NLOS") :]
    print(table)  # the measured table (pytest -s shows it)
    return table


def test_paper_table1_replayed_on_a_simulated_session(tmp_path: Path) -> None:
    """The three NLOS of paper 000 sec. 4.3 (10-20 s, 50-60 s, 90-95 s; N(0.45 / 0.5 / 0.6,
    0.1^2)) injected into the paper-table1 pair without its own NLOS: DI-Based finds each at
    its first range and estimates it within Table 1's largest DI error, closer than RN-Based."""
    sim = simulate("paper-table1", seed=0, nlos_events=[])
    write_simulation(sim, tmp_path / "s")
    _cli("run", str(tmp_path / "s"), "-o", str(tmp_path / "plain"), "--no-figures", "-q")
    assert not (tmp_path / "plain" / "injected_scores.csv").exists()
    events = [
        ("A-B", "+10", "+20", "0.45", "0.1"),
        ("A-B", "+50", "+60", "0.5", "0.1"),
        ("A-B", "+90", "+95", "0.6", "0.1"),
    ]
    out = _inject_and_run(tmp_path / "s", tmp_path, events, seed=0)
    scores = pd.read_csv(out / "injected_scores.csv")
    di, rn = scores[scores["method"] == "di"], scores[scores["method"] == "rn"]
    assert list(di["event"]) == ["nlos1", "nlos2", "nlos3"]
    assert list(di["injected_mean"]) == [0.45, 0.5, 0.6]
    assert (di["detected"] == 1).all() and (di["events"] == 1).all()
    assert (di["delay"].abs() < 0.05).all()  # flagged at the first NLOS range
    assert (di["error"].abs() <= PAPER_DI_MAX_ERROR_M).all(), di
    assert di["error"].abs().mean() < rn["error"].abs().mean()  # Table 1: DI beats RN
    table = _table(out)
    assert "nlos3 A-B" in table and "DI-Based" in table and "RN-Based" in table


def _real_step(out: Path, injected: pd.DataFrame, pair: str, onset: float) -> float:
    """How much the real range error (observed - reference, the injected error taken out)
    changes at ``onset``: mean over the M s from it minus mean over the M s before."""
    ranges = pd.read_csv(out / "ranges.csv")
    ranges = ranges[ranges["pair"] == pair]
    added = injected[(injected["pair"] == pair) & (injected["kind"] == "nlos")]
    lookup = dict(zip(np.round(added["time"], 6), added["error"], strict=True))
    t = ranges["time"].to_numpy()
    own = [lookup.get(round(x, 6), 0.0) for x in t]
    real = ranges["observed"].to_numpy() - ranges["reference"].to_numpy() - np.asarray(own)
    after, before = (t >= onset) & (t < onset + M_S), (t < onset) & (t >= onset - M_S)
    return float(np.nanmean(real[after]) - np.nanmean(real[before]))


@pytest.mark.skipif(
    not (TIERS / "session.toml").is_file(), reason="../shared/data/real/tiers is not present"
)
@pytest.mark.slow
def test_injected_nlos_on_the_real_tiers_session(tmp_path: Path) -> None:
    """Acceptance: three NLOS events (0.5, 1.0, 1.5 m; sd 0.1 m as paper 000 Table 1;
    12 s each) on line-of-sight pairs of the real 64 s TIERS session, none with tb4.

    DI-Based must detect each at its first range and estimate its mean within Table 1's
    largest DI error (0.0368 m) plus what the real data add at that moment: the real range
    error (against the motion-capture reference) is not white, and a change of it at the
    onset is part of the jump the method measures; it is measured here per event (0.003,
    0.010 and 0.024 m for these windows), so the bound is 0.040, 0.047 and 0.061 m.
    """
    events = [
        ("tb2-tb3", "+8", "+20", "0.5", "0.1"),
        ("tb6-tb7", "+25", "+37", "1.0", "0.1"),
        ("tb5-tb7", "+45", "+57", "1.5", "0.1"),
    ]
    # Table 1's bound is for paper 000's DR DI, the navigation as recorded. With the
    # default's DR DI corrected by the DR states the errors were -0.023 / 0.053 / 0.019 m
    # (as recorded -0.022 / 0.000 / 0.027 m): the DR DI's own error over the event moves
    # the estimate, and the real error of tb6-tb7's DR DI over its event is 0.2-0.5 m
    # against the motion capture, either way
    paper = tmp_path / "paper.toml"
    paper.write_text("[ranging.di]\ndr_states = false\n", encoding="utf-8")
    out = _inject_and_run(TIERS, tmp_path, events, 0, "--config", str(paper))
    injected = pd.read_csv(tmp_path / "new" / "injected.csv")
    # the windows are line of sight in the recording (truth/nlos.csv: |range error| > 0.3 m)
    spans = pd.read_csv(TIERS / "truth" / "nlos.csv")
    for event, group in injected.groupby("event"):
        pair, start, end = group["pair"].iloc[0], group["start"].iloc[0], group["end"].iloc[0]
        mine = spans[spans["pair"] == pair]
        assert not ((mine["start"] <= end) & (mine["end"] >= start)).any(), event
    scores = pd.read_csv(out / "injected_scores.csv")
    assert sorted(set(scores["method"])) == ["di", "rn"] and len(scores) == 6
    di = scores[scores["method"] == "di"].set_index("event")
    for event, group in injected.groupby("event"):
        row = di.loc[event]
        step = _real_step(out, injected, str(row["pair"]), float(group["time"].min()))
        assert row["detected"] == 1 and row["events"] == 1, (event, row)
        assert abs(row["delay"]) < 0.5, (event, row)
        assert abs(row["error"]) <= PAPER_DI_MAX_ERROR_M + abs(step), (event, row, step)
    assert (scores[scores["method"] == "rn"]["detected"] == 1).all()
    _table(out)
