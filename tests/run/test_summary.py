"""The closing summary: method lists from the run, and the warning when fusion hurts."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pandas as pd

from coopproc.run.summary import summarize


def _output(nav: float, observed: float, di: float) -> Any:
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
    )
    return SimpleNamespace(
        result=result,
        methods={"ranges": ("observed", "di"), "positions": ("observed", "di")},
        nlos_methods=("di",),
    )


def test_lines_follow_the_run_methods() -> None:
    summary = summarize(_output(0.3, 0.2, 0.1))
    assert summary.lines[0] == "NLOS events (DI-Based): 1 on 1 pairs"
    assert summary.lines[1] == ("  A-B: 1 events, range RMSE observed 0.200 m, DI 0.050 m (-75.0%)")
    assert not any(line.startswith("warning") for line in summary.lines)
    assert "worse_than_nav" not in summary.facts


def test_fused_worse_than_own_navigation_is_said() -> None:
    summary = summarize(_output(0.05, 0.40, 0.35))
    assert summary.facts["worse_than_nav"] == ["A"]
    assert summary.lines[-1].startswith("warning: the fused positions of A are worse than")
    # within 10 % / 2 cm of the navigation it is not
    assert "worse_than_nav" not in summarize(_output(0.30, 0.32, 0.31)).facts
