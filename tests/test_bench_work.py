"""The benchmarks' work record and verdict (benchmarks/_work.py, issue 35): a target says
met or missed only on a run that did the work, judged against the simulator's truth.

Synthetic run directories and truth (no `coopproc run`, no timing)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from _common import _phase_peaks, target
from _work import MIN_RECALL, overlaps, read_work, smoothable_pairs, verdict

PAIRS = ("P00-P01", "P00-P02", "P01-P02")


def _truth_events() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "pair": ["P00-P01", "P00-P01", "P00-P02", "P01-P02"],
            "start": [100.0, 400.0, 200.0, 50.0],
            "end": [120.0, 420.0, 230.0, 60.0],
        }
    )


def _found_events() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "pair": ["P00-P01", "P00-P01", "P00-P02", "P00-P02", "P01-P02"],
            "method": ["di", "di", "di", "rn", "di"],
            # 121 s starts within the 1 s slack of 100-120; 300-310 overlaps no event;
            # 205-215 inside 200-230; 61.5 s starts 1.5 s after 50-60 ends: not matched
            "start": [121.0, 300.0, 205.0, 190.0, 61.5],
            "end": [125.0, 310.0, 215.0, 199.5, 64.0],
            "epochs": [5, 11, 11, 10, 3],
            "estimate": [0.5] * 5,
        }
    )


def test_overlaps_counts_found_and_false_events() -> None:
    events = _found_events()
    assert overlaps(events[events["method"] == "di"], _truth_events()) == (2, 2)
    # the RN event ends 0.5 s before the true one starts: within the slack
    assert overlaps(events[events["method"] == "rn"], _truth_events()) == (1, 0)


def _run_dir(tmp_path: Path, *, rn_reused: bool) -> tuple[Path, Path]:
    out, session = tmp_path / "out", tmp_path / "session"
    out.mkdir(parents=True)
    (session / "truth").mkdir(parents=True)
    facts = {
        "P00-P01": {"passthrough": False, "ranges_only_fraction": 0.0},
        "P00-P02": {"passthrough": False, "ranges_only_fraction": 0.4},
        "P01-P02": {"passthrough": True, "ranges_only_fraction": 1.0},
    }
    notes = ["fusion (observed): something else"]
    if rn_reused:
        notes.append(
            "fusion (rn): the rn ranges are the observed ones (the range processing changed "
            "none): its fusion is the observed fusion, reused, not run again"
        )
    info = {
        "calibration": {
            "ranging": {p: {"di": f, "rn": {**f, "passthrough": False}} for p, f in facts.items()},
            "notes": notes,
        },
        "timings_s": {"fusion (observed)": 1.0, "fusion (rn)": 0.0, "fusion (di)": 0.5},
    }
    (out / "run.json").write_text(json.dumps(info))
    _found_events().to_csv(out / "nlos_events.csv", index=False)
    _truth_events().to_csv(session / "truth" / "nlos_events.csv", index=False)
    return out, session


def test_work_record_and_verdict(tmp_path: Path) -> None:
    out, session = _run_dir(tmp_path, rn_reused=True)
    can = dict.fromkeys(PAIRS, True)
    work = read_work(out, session, can)
    assert work.modes["di"] == {"smoothing": 1, "ranges-only": 1, "passed through": 1}
    assert work.modes["rn"] == {"smoothing": 1, "ranges-only": 2, "passed through": 0}
    assert work.events == {"di": (2, 4, 2), "rn": (1, 4, 0)}
    assert work.fusions == {"rn": "reused", "di": "run"}
    assert work.passed_smoothable == ["P01-P02"]
    assert work.smoothable == 3 and work.pairs == 3
    assert work.recall("di") == 0.5
    assert work.cells().split() == ["1/1/1", "1/2/0", "2/4/2", "1/4/0", "uR"]
    why = verdict(work)
    assert why == (
        "1 pair passed through whose dead reckoning can smooth (P01-P02); "
        "DI found 2 of 4 NLOS events (< 90%)"
    )
    # the pair's dead reckoning cannot smooth: passing it through is the method's answer
    work = read_work(out, session, {**can, "P01-P02": False})
    assert work.passed_smoothable == []
    assert verdict(work) == "DI found 2 of 4 NLOS events (< 90%)"
    work.events["di"] = (4, 4, 2)
    assert verdict(work) is None
    work.events["di"] = (0, 0, 0)
    assert verdict(work) == "no simulated NLOS event to find"
    out2, session2 = _run_dir(tmp_path / "b", rn_reused=False)
    assert read_work(out2, session2, can).fusions == {"rn": "run", "di": "run"}
    assert MIN_RECALL == 0.9


def test_target_prints_not_comparable() -> None:
    assert target("x <= 2 s", 1.0, 2.0, at_most=True) == "target x <= 2 s: met (ratio 0.50)"
    assert target("x <= 2 s", 3.0, 2.0, at_most=True) == "target x <= 2 s: missed (ratio 1.50)"
    line = target("x <= 2 s", 1.0, 2.0, at_most=True, incomplete="no work")
    assert line == "target x <= 2 s: not comparable: no work (ratio 0.50)"


@pytest.mark.parametrize(("step_m", "smooth"), [(0.01, True), (0.3, False)])
def test_smoothable_pairs_from_the_true_dr_error(
    tmp_path: Path, step_m: float, smooth: bool
) -> None:
    """P01 sits 20 m east of P00; its DR error walks east by ``step_m`` per second:
    q = step^2 against R = 0.08^2 gives a steady gain of 0.12 (smooths) or 0.98."""
    truth = tmp_path / "truth"
    truth.mkdir()
    (truth / "params.toml").write_text('scenario = "large"\nseed = 0\nuwb_noise_m = 0.08\n')
    t = np.arange(900.0)
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.normal(0.0, step_m, t.size))
    err = pd.concat(
        [
            pd.DataFrame({"time": t, "platform": "P00", "error_east": 0.0, "error_north": 0.0}),
            pd.DataFrame({"time": t, "platform": "P01", "error_east": walk, "error_north": 0.0}),
        ]
    )
    err.to_csv(truth / "dr_error.csv", index=False)
    for name, east in (("P00", 0.0), ("P01", 20.0)):
        pd.DataFrame({"time": t, "east": east, "north": 5.0}).to_csv(
            truth / f"traj_{name}.csv", index=False
        )
    pd.DataFrame({"time": [0.5], "pair": ["P00-P01"]}).to_csv(truth / "distances.csv")
    assert smoothable_pairs(tmp_path) == {"P00-P01": smooth}
    # the threshold is the ranging stage's rule: at a gain limit of 0.05 nothing smooths
    assert smoothable_pairs(tmp_path, passthrough_gain=0.05) == {"P00-P01": False}


def test_a_phase_peak_is_the_largest_sample_between_its_line_and_the_one_before() -> None:
    samples = [(0.5, 10), (1.0, 50), (1.5, 20), (2.5, 70), (3.0, 30), (3.05, 40)]
    ends = [("read", 1.2), ("fusion", 3.0), ("html", 3.02), ("read", 3.1)]
    # read: samples in (0, 1.2]; fusion: (1.2, 3.0]; html: none in (3.0, 3.02], so the
    # sample nearest its end (3.0 s: 30); a label seen twice keeps its larger peak
    assert _phase_peaks(samples, 0.0, ends) == {"read": 50, "fusion": 70, "html": 30}
    assert _phase_peaks([], 0.0, ends) == {}
