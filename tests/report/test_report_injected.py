"""injected_scores.csv: the methods scored against what `coopproc inject` injected."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.io.injected import INJECTED_COLUMNS
from coopproc.io.outdir import write_csv
from coopproc.model import NLOS_EVENT_COLUMNS
from coopproc.report.formats import format_tables
from coopproc.report.html import render_html
from coopproc.report.injected import INJECTED_SCORE_COLUMNS, injected_scores, injected_table
from coopproc.report.rundir import RUN_EXTENSION_FILES, RUN_FILES, load_run
from tests.report.report_synth import make_run


def _injected() -> pd.DataFrame:
    rows = [
        (t, "A-B", "nlos", 0.5 + 0.01 * i, "nlos1", 10.0, 20.0, 0.5, 0.1)
        for i, t in enumerate(np.arange(10.0, 20.01, 1.0))
    ]
    rows += [
        (t, "B-C", "nlos", 1.0, "nlos2", 30.0, 40.0, 1.0, 0.0) for t in np.arange(30.0, 40.01, 1.0)
    ]
    rows += [
        (25.0, "A-B", "gross", 2.0, "gross1", 25.0, 25.0, 2.0, np.nan),
        (50.0, "A-B", "outage", np.nan, "outage1", 50.0, 52.0, np.nan, np.nan),
    ]
    return pd.DataFrame(rows, columns=list(INJECTED_COLUMNS))  # fmt: skip


def _events() -> pd.DataFrame:
    rows = [
        ("A-B", "di", 10.0, 17.0, 8, 0.52),  # the longest overlap: its estimate is scored
        ("A-B", "di", 18.0, 20.0, 3, 0.90),
        ("A-B", "rn", 5.0, 12.0, 8, 0.30),  # already running before the first injected range
        ("B-C", "rn", 50.0, 60.0, 11, 1.2),  # after the window: not a detection
        ("A-C", "di", 30.0, 40.0, 11, 1.0),  # another pair
    ]
    return pd.DataFrame(rows, columns=list(NLOS_EVENT_COLUMNS))


def test_each_event_and_method_scored_against_the_injected_mean() -> None:
    scores = injected_scores(_injected(), _events(), ("rn", "di"))
    assert tuple(scores.columns) == INJECTED_SCORE_COLUMNS
    assert list(zip(scores["event"], scores["method"], strict=True)) == [
        ("nlos1", "rn"), ("nlos1", "di"), ("nlos2", "rn"), ("nlos2", "di"),
    ]  # fmt: skip
    di = scores.iloc[1]
    assert (di["pair"], di["start"], di["end"], di["epochs"]) == ("A-B", 10.0, 20.0, 11)
    assert di["injected_mean"] == 0.5 and di["realized_mean"] == pytest.approx(0.55)
    assert di["estimated"] == 0.52 and di["error"] == pytest.approx(0.02)
    assert di["error_pct"] == pytest.approx(4.0)
    assert (di["detected"], di["events"], di["delay"]) == (1, 2, 0.0)
    rn = scores.iloc[0]
    assert rn["estimated"] == 0.30 and rn["error"] == pytest.approx(-0.2)
    assert rn["error_pct"] == pytest.approx(40.0) and rn["delay"] == -5.0
    for row in (scores.iloc[2], scores.iloc[3]):
        assert row["detected"] == 0 and row["events"] == 0
        assert np.isnan([row["estimated"], row["error"], row["delay"]]).all()


def test_no_nlos_injected_means_no_rows() -> None:
    only_gross = _injected()[lambda f: f["kind"] != "nlos"]
    scores = injected_scores(only_gross, _events(), ("rn", "di"))
    assert scores.empty and tuple(scores.columns) == INJECTED_SCORE_COLUMNS


def test_table_groups_events_and_marks_the_best() -> None:
    table = injected_table(
        injected_scores(_injected(), _events(), ("di", "rn")), order=("rn", "di")
    )
    assert table.group_label == "Event"
    assert [(r.group, r.method) for r in table.rows[:2]] == [
        ("nlos1 A-B", "rn"),
        ("nlos1 A-B", "di"),
    ]
    assert "error" in table.rows[1].best and "error" not in table.rows[0].best
    assert "detected" not in table.rows[0].best  # both detected: nothing is best
    assert table.header("error") == "Error (m)" and table.header("delay") == "Delay (s)"


@pytest.mark.slow
def test_run_directory_round_trip_and_report(tmp_path: Path) -> None:
    scores = injected_scores(_injected(), _events(), ("rn", "di"))
    run = dataclasses.replace(make_run(), injected_scores=scores)
    out = tmp_path / "out"
    out.mkdir()
    for name, attr, columns, _required in (*RUN_FILES, *RUN_EXTENSION_FILES):
        if getattr(run, attr) is not None:
            write_csv(getattr(run, attr), out / name, columns)
    (out / "run.json").write_text(json.dumps({}))
    back = load_run(out)
    assert back.injected_scores is not None
    pd.testing.assert_frame_equal(back.injected_scores, scores, check_dtype=False)
    text = format_tables(back, "terminal")
    assert "Injected NLOS: estimates against the injected mean" in text
    assert "nlos1 A-B" in text and "best of the column within each event" in text
    assert "nlos2" not in format_tables(back, "md", pairs=["A-B"])
    assert "Injected" not in format_tables(back, "csv", metrics=["rmse"])
    page = render_html(out, back)
    assert "Injected NLOS: estimates against the injected mean" in page
    assert (
        page.count("<table")
        == render_html(out, dataclasses.replace(back, injected_scores=None)).count("<table") + 1
    )
    (out / "injected_scores.csv").unlink()
    plain = load_run(out)
    assert plain.injected_scores is None
    assert "Injected" not in format_tables(plain, "latex")
    assert "Injected" not in render_html(out, plain)
