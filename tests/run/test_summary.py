"""The closing summary: method lists from the run, and the warning when fusion hurts."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pandas as pd

from coopproc.run.summary import summarize


def _output(
    nav: float,
    observed: float,
    di: float,
    weights: pd.DataFrame | None = None,
    outlier_scores: pd.DataFrame | None = None,
) -> Any:
    pm = pd.DataFrame(
        {
            "platform": ["A"] * 3 + ["B"] * 3,
            "method": ["nav", "observed", "di"] * 2,
            "mean": [nav, observed, di, 0.30, 0.20, 0.10],
        }
    )
    metrics = pd.DataFrame({"pair": ["A-B"] * 2, "method": ["observed", "di"], "rmse": [0.2, 0.05]})
    events = pd.DataFrame({"pair": ["A-B"], "method": ["di"]})
    result = SimpleNamespace(
        nlos_events=events,
        ranges=pd.DataFrame({"pair": ["A-B"]}),
        metrics=metrics,
        position_metrics=pm,
        range_weights=weights,
    )
    return SimpleNamespace(
        result=result,
        methods={"ranges": ("observed", "di"), "positions": ("observed", "di")},
        nlos_methods=("di",),
        fusion_outlier_scores=outlier_scores,
        ranging_calibration={},
    )


def test_lines_follow_the_run_methods() -> None:
    summary = summarize(_output(0.3, 0.2, 0.1))
    assert summary.lines[0] == "NLOS events (DI-Based): 1 on 1 pair"
    assert summary.lines[1] == "  A-B: 1 event, range RMSE observed 0.200 m, DI 0.050 m (-75.0%)"
    assert summary.lines[2] == (
        "  A: mean horizontal error own nav 0.300 m, fused observed 0.200 m, fused DI 0.100 m "
        "(-50.0%)"
    )
    assert not any(line.startswith("warning") for line in summary.lines)
    assert "worse_than_nav" not in summary.facts


def test_fused_worse_than_own_navigation_is_said() -> None:
    summary = summarize(_output(0.05, 0.40, 0.35))
    assert summary.facts["worse_than_nav"] == ["A"]
    assert summary.lines[-1].startswith("warning: the fused positions of A are worse than")
    # within 10 % / 2 cm of the navigation it is not
    assert "worse_than_nav" not in summarize(_output(0.30, 0.32, 0.31)).facts


def _three_pairs(events: list[str], rmse: dict[str, tuple[float, float]]) -> Any:
    """Three pairs, DI events on ``events`` (one each), observed and DI RMSE per pair."""
    out = _output(0.3, 0.2, 0.1)
    pairs = ["A-B", "A-C", "B-C"]
    out.result.ranges = pd.DataFrame({"pair": pairs})
    out.result.nlos_events = pd.DataFrame({"pair": events, "method": ["di"] * len(events)})
    out.result.metrics = pd.DataFrame(
        {
            "pair": [p for p in pairs for _ in range(2)],
            "method": ["observed", "di"] * 3,
            "rmse": [v for p in pairs for v in rmse[p]],
        }
    )
    return out


def test_the_header_counts_the_pairs_with_events() -> None:
    rmse = {"A-B": (0.2, 0.05), "A-C": (0.1, 0.1), "B-C": (0.2, 0.1)}
    lines = summarize(_three_pairs(["A-B", "A-B", "B-C", "B-C"], rmse)).lines
    assert lines[0] == "NLOS events (DI-Based): 4 on 2 of 3 pairs"
    assert lines[1].startswith("  A-B: 2 events, ")
    assert lines[2].startswith("  A-C: 0 events, ")
    assert summarize(_three_pairs(["A-B", "A-C", "B-C"], rmse)).lines[0] == (
        "NLOS events (DI-Based): 3 on all 3 pairs"
    )
    assert summarize(_three_pairs([], rmse)).lines[0] == "NLOS events (DI-Based): none on 3 pairs"
    assert summarize(_three_pairs(["B-C"], rmse)).lines[3].startswith("  B-C: 1 event, ")


def test_changes_say_no_change_and_metres_near_zero() -> None:
    """No signed zero ("-0.0%"); a change of a value under 1 cm in metres, not percent."""
    rmse = {"A-B": (0.2, 0.19999), "A-C": (0.004, 0.006), "B-C": (0.005, 0.005)}
    lines = summarize(_three_pairs(["A-B"], rmse)).lines
    assert lines[1] == "  A-B: 1 event, range RMSE observed 0.200 m, DI 0.200 m (no change)"
    assert lines[2] == "  A-C: 0 events, range RMSE observed 0.004 m, DI 0.006 m (+0.002 m)"
    assert lines[3] == "  B-C: 0 events, range RMSE observed 0.005 m, DI 0.005 m (no change)"
    # a platform whose fused error equals its observed one to the printed digits
    same = summarize(_output(0.025, 0.0250, 0.025004)).lines[2]
    assert same.endswith("fused DI 0.025 m (no change)"), same


def test_fusion_outliers_line_and_facts() -> None:
    """One line for the fusion's IGG-III decisions, the methods in the run's order, and
    the counts in the facts (run.json summary.fusion_outliers)."""
    weights = pd.DataFrame(
        {
            "method": ["di"] * 3 + ["observed"] * 4,
            "gamma": [1.0, 0.5, 1.0, 1.0, 0.3, 1e-30, 1e-30],
            "rejected": [0, 0, 0, 0, 0, 1, 1],
        }
    )
    scores = pd.DataFrame(
        {
            "method": ["fusion:observed", "fusion:di"],
            "epochs": [4, 3],
            "nlos_true": [2, 0],
            "tp": [2, 0],
            "rejected_tp": [1, 0],
        }
    )
    summary = summarize(_output(0.3, 0.2, 0.1, weights, scores))
    line = next(x for x in summary.lines if x.startswith("fusion down-weighted"))
    assert line == (
        "fusion down-weighted 3 of 4 ranges (2 rejected) in observed, 2 (1) of the 2 > 3 "
        "sigma off the reference; DI 1 (0), 0 (0) of 0 (range_weights.csv)"
    )
    assert summary.facts["fusion_outliers"]["observed"] == {
        "ranges": 4,
        "down_weighted": 3,
        "rejected": 2,
        "scored": 4,
        "outliers": 2,
        "down_weighted_outliers": 2,
        "rejected_outliers": 1,
    }
    assert list(summary.facts["fusion_outliers"]) == ["observed", "di"]
