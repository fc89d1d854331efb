"""UWB outage windows (paper 003 sec. 3.4, issue 12 item 5): the ranges inside reach no
method, ranges.csv still lists them, outages.csv scores the drift, the windows are checked."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.checks.coverage import prepare_run, session_start_s
from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.io import read_session
from coopproc.model import Session
from coopproc.report.outage import OUTAGE_COLUMNS
from coopproc.report.outage_figure import outage_panels
from coopproc.report.pages import FigureOptions
from coopproc.report.rundir import load_run
from coopproc.run.chain import PipelineParams
from coopproc.run.config import RunConfig, RunParams
from coopproc.run.outages import OutageOutput, check_windows, parse_outage, withhold
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate, write_simulation


def _make(root: Path, **extra: object) -> Path:
    """A 90-s land-vehicle session with 4 anchors, no IMU files (the DR-based methods
    only), no scenario outage or NLOS, no float reference (every epoch scored)."""
    sim = simulate(
        "land-vehicle",
        seed=0,
        duration_s=90.0,
        platforms=5,
        imu_rate_hz=0.0,
        outages=[],
        nlos_events=[],
        float_fraction=0.0,
        **extra,
    )
    write_simulation(sim, root)
    return root


@pytest.fixture(scope="module")
def session_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _make(tmp_path_factory.mktemp("outage") / "lv")


@pytest.fixture(scope="module")
def session(session_dir: Path) -> Session:
    return prepare_run(read_session(session_dir))[0]


def _config(*windows: tuple[float, float], ranges: tuple[str, ...] = ()) -> RunConfig:
    return RunConfig(
        run=RunParams(outages=tuple(windows), figures=False),
        pipeline=PipelineParams(ranges=ranges, positions=("fusion",)),
    )


def test_windows_are_checked_in_one_line(session: Session) -> None:
    cases = [
        ([(40.0, 40.0)], "outage 40:40: the end must be after the start"),
        ([(50.0, 45.0)], "outage 50:45: the end must be after the start"),
        ([(-1.0, 10.0)], "outage -1:10: reaches outside the session, which spans 0-90.0 s"),
        ([(80.0, 95.0)], "outage 80:95: reaches outside the session"),
        ([(30.0, 50.0), (10.0, 31.0)], "outages 10:31 and 30:50 overlap"),
    ]
    for given, message in cases:
        with pytest.raises(ConfigError) as caught:
            check_windows(given, session)
        assert message in str(caught.value) and "\n" not in str(caught.value)
    # touching windows are two stretches, given in any order
    windows = check_windows([(50.0, 60.0), (40.0, 50.0)], session)
    assert [(w.start_s, w.end_s) for w in windows] == [(40.0, 50.0), (50.0, 60.0)]
    assert windows[0].start == pytest.approx(session_start_s(session) + 40.0)
    assert parse_outage("100:130.5") == (100.0, 130.5)
    for bad in ("100", "a:b", "1:inf", ""):
        with pytest.raises(ValueError, match=r"T0:T1|finite"):
            parse_outage(bad)


def test_withhold_removes_exactly_the_ranges_inside(session: Session) -> None:
    t = session.ranges.frame["time"].to_numpy() - session_start_s(session)
    # a window whose ends are range epochs: both ends are withheld
    start, end = float(t[t > 20.0][0]), float(t[t > 30.0][0])
    windows = check_windows([(start, end), (60.0, 61.5)], session)
    kept, counts = withhold(session, windows)
    inside = ((t >= start) & (t <= end)) | ((t >= 60.0) & (t <= 61.5))
    assert counts == [int(((t >= start) & (t <= end)).sum()), int(((t >= 60) & (t <= 61.5)).sum())]
    assert len(kept.ranges) == int((~inside).sum()) and inside.sum() > 10
    pd.testing.assert_frame_equal(
        kept.ranges.frame, session.ranges.frame[~inside].reset_index(drop=True)
    )


def test_withheld_ranges_reach_no_method_but_stay_in_ranges_csv(session: Session) -> None:
    window = (30.0, 45.0)
    with_outage = run_pipeline(session, _config(window, ranges=("rn",)))
    kept, _ = withhold(session, check_windows([window], session))
    cut_config = RunConfig(
        run=RunParams(positions_at="nav", figures=False),
        pipeline=PipelineParams(ranges=("rn",), positions=("fusion",)),
    )
    cut = run_pipeline(kept, cut_config)
    # every method saw exactly the session without the window's ranges
    pd.testing.assert_frame_equal(with_outage.result.positions, cut.result.positions)
    pd.testing.assert_frame_equal(with_outage.result.metrics, cut.result.metrics)
    ranges = with_outage.result.ranges
    t = ranges["time"].to_numpy() - session_start_s(session)
    inside = (t >= window[0]) & (t <= window[1])
    assert len(ranges) == len(session.ranges) and inside.sum() > 50
    assert ranges.loc[inside, "rn"].isna().all() and ranges.loc[~inside, "rn"].notna().all()
    assert ranges.loc[inside, "observed"].notna().all()
    assert (ranges.loc[inside, "nlos_flag"] == 0).all()
    assert any("ranges withheld from every method" in n for n in with_outage.notes)
    # positions at the navigation rate (10 Hz) inside the window
    rows = with_outage.result.positions
    own = rows[(rows["method"] == "observed")]
    t_pos = own["time"].to_numpy() - session_start_s(session)
    assert ((t_pos >= 31.0) & (t_pos <= 44.0)).sum() >= 130


def test_drift_grows_with_outage_length(tmp_path: Path) -> None:
    # nested windows from the same start on a car whose heading drifts at 3 deg/min
    # (the dr-faults size): the fused (RTS-bridged) solution's largest and RMS error
    # inside grow with the length, as in paper 003 Fig. 10
    root = _make(tmp_path / "drift", heading_drift_dpm=3.0)
    session = prepare_run(read_session(root))[0]
    rows = []
    for length in (3.0, 10.0, 25.0, 50.0):
        output = run_pipeline(session, _config((30.0, 30.0 + length)))
        assert isinstance(output, OutageOutput) and output.outages is not None
        table = output.outages.table
        row = table[table["method"] == "observed"].iloc[0]
        assert row["length_s"] == length and row["epochs"] == 10 * length + 1
        rows.append(row)
    for first, second in itertools.pairwise(rows):
        assert second["error_max"] > first["error_max"]
        assert second["error_rms"] > first["error_rms"]
    assert rows[-1]["error_max"] > 5 * rows[0]["error_max"]


def test_run_and_report_through_files(session_dir: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    config = tmp_path / "run.toml"
    config.write_text("[pipeline]\nranges = []\nanchor_methods = false\n")  # the fusion only
    out = tmp_path / "out"
    args = ["run", str(session_dir), "-o", str(out), "--config", str(config), "--no-figures"]
    made = runner.invoke(main, [*args, "--outage", "50:60", "--outage", "20:30"])
    assert made.exit_code == 0, made.output
    assert "note: [run] outages:" in made.output
    table = pd.read_csv(out / "outages.csv")
    assert tuple(table.columns) == OUTAGE_COLUMNS
    assert list(table["window"]) == [1, 1, 2, 2]
    assert list(table["method"]) == ["nav", "observed"] * 2
    info = json.loads((out / "run.json").read_text())
    ranges = pd.read_csv(out / "ranges.csv")
    t = ranges["time"].to_numpy() - info["outages"]["windows"][0]["start"] + 20.0
    inside = ((t >= 20) & (t <= 30)) | ((t >= 50) & (t <= 60))
    assert info["outages"]["withheld"] == int(inside.sum()) > 0
    assert [w["start_s"] for w in info["outages"]["windows"]] == [20.0, 50.0]
    assert info["config"]["run"]["outages"] == [[50.0, 60.0], [20.0, 30.0]]
    for fmt, marker in (
        ("terminal", "Horizontal position error inside each UWB outage"),
        ("csv", "window,span,length_s"),
        ("md", "| Window | Span (s) |"),
        ("latex", "\\label{tab:outages}"),
    ):
        shown = runner.invoke(main, ["report", str(out), "--outages", "--format", fmt])
        assert shown.exit_code == 0, shown.output
        assert marker in shown.output and "20.0-30.0" in shown.output
        if fmt == "terminal":  # display names in the other tables' order, not raw ids
            methods = [line.split()[3:5] for line in shown.output.splitlines()[4:-1]]
            assert methods == [["car", "Own"], ["car", "Observed"]] * 2, shown.output
    # the figure: per method one line per window, from 0 s since the outage start
    panels = outage_panels(load_run(out), FigureOptions())
    assert panels is not None and list(panels.keys) == ["car"]
    fig = panels.page([0])
    ax = fig.axes[0]
    lines = [line for line in ax.get_lines() if len(line.get_xdata())]
    assert len(lines) == 4
    assert all(np.min(line.get_xdata()) == 0.0 for line in lines)
    assert max(np.max(line.get_xdata()) for line in lines) == pytest.approx(10.0)
    # the two windows told apart: a marker each, and legend entries with their spans
    by_window = {}
    for line in lines:
        by_window.setdefault(line.get_color(), []).append(line.get_marker())
    assert all(markers == ["o", "s"] for markers in by_window.values())
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["Own nav", "Observed", "Window 1: 20.0-30.0 s", "Window 2: 50.0-60.0 s"]
    (out / "outages.csv").unlink()
    missing = runner.invoke(main, ["report", str(out), "--outages"])
    assert missing.exit_code == 1 and "the run had no outage windows" in missing.output
    # bad windows: one line, before any output is written
    for window, message in (
        ("40:30", "error: outage 40:30: the end must be after the start"),
        ("80:120", "reaches outside the session"),
    ):
        bad = runner.invoke(main, [*args, "--force", "--outage", window])
        assert bad.exit_code == 1 and message in bad.output
        assert len(bad.output.strip().splitlines()[-1:]) == 1 and "Traceback" not in bad.output
    usage = runner.invoke(main, [*args, "--force", "--outage", "abc"])
    assert usage.exit_code == 2 and "expected T0:T1" in usage.output


REAL_TUC = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real" / "tuc"


def test_real_tuc_windows_withheld_and_fusion_bridges_them() -> None:
    # real wheel odometry and UWB to 4 anchors (../shared/data/real/tuc, 30 s): two
    # windows; inside them the fused solution stays far better than the odometry
    if not REAL_TUC.is_dir():
        pytest.skip("shared/data/real is not present")
    session = prepare_run(read_session(REAL_TUC))[0]
    output = run_pipeline(session, _config((10.0, 15.0), (18.0, 25.0)))
    assert isinstance(output, OutageOutput) and output.outages is not None
    t = session.ranges.frame["time"].to_numpy() - session_start_s(session)
    inside = ((t >= 10.0) & (t <= 15.0)) | ((t >= 18.0) & (t <= 25.0))
    assert sum(output.outages.withheld) == int(inside.sum()) > 50
    table = output.outages.table.set_index(["window", "method"])
    for window in (1, 2):
        assert table.loc[(window, "observed"), "epochs"] > 30
        nav_max = table.loc[(window, "nav"), "error_max"]
        assert table.loc[(window, "observed"), "error_max"] < 0.5 * nav_max
