"""Navigation that does not cover the ranges: validate warns, run leaves those ranges out
(with notes that reach run.json), and the figures draw nothing across a gap."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from matplotlib.figure import Figure

from coopproc.checks.coverage import coverage_warnings, restrict_to_coverage
from coopproc.cli import main
from coopproc.io import read_session
from coopproc.report.figures import make_figures
from coopproc.report.plots import plot_position_errors
from coopproc.report.rundir import load_run

T0 = 108000.0  # the simulator's first epoch (gps_tow)
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cov") / "clean"
    args = ["--scenario", "paper-experiment", "--seed", "5", "--duration", "240"]
    res = CliRunner().invoke(main, ["simulate", str(path), *args])
    assert res.exit_code == 0, res.output
    return path


def _cut(path: Path, keep: object) -> None:
    """Keep the nav rows whose time (s from T0) satisfies ``keep``."""
    nav = pd.read_csv(path, comment="#")
    rel = nav["time"].to_numpy() - T0
    nav[keep(rel)].to_csv(path, index=False, float_format="%.6f")  # type: ignore[operator]


@pytest.fixture
def holed(simulated: Path, tmp_path: Path) -> Path:
    """A's nav starts at 10 s, B's has a gap 60-120 s, C's ends at 200 s."""
    path = tmp_path / "holed"
    shutil.copytree(simulated, path)
    _cut(path / "nav_A.csv", lambda t: t >= 10.0 - 1e-6)
    _cut(path / "nav_B.csv", lambda t: (t <= 60.0 + 1e-6) | (t >= 120.0 - 1e-6))
    _cut(path / "nav_C.csv", lambda t: t <= 200.0 + 1e-6)
    return path


def _ranges(path: Path) -> pd.DataFrame:
    frame = pd.read_csv(path / "ranges.csv")
    frame["rel"] = frame["time"] - T0
    return frame


def _with(frame: pd.DataFrame, pid: str) -> pd.DataFrame:
    return frame[(frame["from"] == pid) | (frame["to"] == pid)]


def test_clean_session_is_returned_unchanged(simulated: Path) -> None:
    session = read_session(simulated)
    assert coverage_warnings(session) == []
    assert restrict_to_coverage(session) == (session, [])
    sample = read_session(REPO / "sample_logs")
    assert restrict_to_coverage(sample)[0] is sample


def test_validate_warns_with_figures_and_exits_0(holed: Path) -> None:
    frame = _ranges(holed)
    first, last = frame["rel"].min(), frame["rel"].max()
    a, b, c = (_with(frame, p) for p in "ABC")
    before_a = int((a["rel"] < 10.0).sum())
    in_gap_b = int(((b["rel"] > 60.0) & (b["rel"] < 120.0)).sum())
    after_c = int((c["rel"] > 200.0).sum())
    assert before_a > 5 and in_gap_b > 50 and after_c > 30
    res = CliRunner().invoke(main, ["validate", str(holed)])
    assert res.exit_code == 0
    lines = res.output.splitlines()
    # the readers' decisions (reference epochs of Q 2 dropped) come as notes, as in run
    notes = [line for line in lines if line.startswith("note: ") and ".pos: " in line]
    assert len(notes) == 3 and all("dropped from the reference" in n for n in notes)
    assert [line for line in lines if line not in notes] == [
        "note: times below are seconds from the session start, 108000.000",
        f"warning: A: navigation starts at 10.0 s, {10.0 - first:.1f} s after the first range "
        f"({first:.1f} s)",
        f"warning: A: {before_a} of {len(a)} ranges of pairs with A are not covered by its "
        f"navigation ({before_a} before its navigation starts); coopproc run leaves them out",
        "warning: B: navigation gap 60.0-120.0 s (60.0 s; gaps are intervals over 0.250 s, "
        "2.5 x the median interval)",
        f"warning: B: {in_gap_b} of {len(b)} ranges of pairs with B are not covered by its "
        f"navigation ({in_gap_b} inside 1 gap); coopproc run leaves them out",
        f"warning: C: navigation ends at 200.0 s, {last - 200.0:.1f} s before the last range "
        f"({last:.1f} s)",
        f"warning: C: {after_c} of {len(c)} ranges of pairs with C are not covered by its "
        f"navigation ({after_c} after its navigation ends); coopproc run leaves them out",
        f"{holed}: ok (6 warnings)",
    ]
    quiet = CliRunner().invoke(main, ["validate", "-q", str(holed)])
    assert (quiet.exit_code, quiet.output) == (0, "")


def test_run_leaves_uncovered_ranges_out_and_notes_them(holed: Path, tmp_path: Path) -> None:
    frame = _ranges(holed)
    a, b, c = (_with(frame, p) for p in "ABC")
    drop = (
        ((frame["from"] == "A") | (frame["to"] == "A")) & (frame["rel"] < 10.0)
        | ((frame["from"] == "B") | (frame["to"] == "B"))
        & (frame["rel"] > 60.0)
        & (frame["rel"] < 120.0)
        | ((frame["from"] == "C") | (frame["to"] == "C")) & (frame["rel"] > 200.0)
    )
    notes = [
        f"excluded {int((a['rel'] < 10.0).sum())} ranges of pairs with A, not covered by its "
        "navigation: "
        f"{int((a['rel'] < 10.0).sum())} before its navigation starts at 10.0 s "
        "(times from the session start 108000.000)",
        f"excluded {int(((b['rel'] > 60.0) & (b['rel'] < 120.0)).sum())} ranges of pairs with "
        "B, not covered by its navigation: "
        f"{int(((b['rel'] > 60.0) & (b['rel'] < 120.0)).sum())} in its gap 60.0-120.0 s "
        "(times from the session start 108000.000)",
        f"excluded {int((c['rel'] > 200.0).sum())} ranges of pairs with C, not covered by its "
        f"navigation: {int((c['rel'] > 200.0).sum())} after its navigation ends at 200.0 s "
        "(times from the session start 108000.000)",
    ]
    session, printed = restrict_to_coverage(read_session(holed))
    assert printed == notes
    assert len(session.ranges) == len(frame) - int(drop.sum())
    assert session.notes[-3:] == tuple(notes)

    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(holed), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    for note in notes:
        assert res.output.count(f"note: {note}\n") == 1
    assert "frame of its own" not in res.output
    assert json.loads((out / "run.json").read_text())["notes"][-3:] == notes
    positions = pd.read_csv(out / "positions.csv")
    rel = positions["time"] - T0
    b_rows = positions[positions["platform"] == "B"]
    assert len(b_rows) and not ((b_rows["time"] - T0 > 60.0) & (b_rows["time"] - T0 < 120.0)).any()
    assert not (rel[positions["platform"] == "A"] < 10.0).any()
    assert not (rel[positions["platform"] == "C"] > 200.0).any()

    # figures: no line of B is drawn across its gap
    run = load_run(out)
    figures = make_figures(run)

    def b_lines(name: str) -> list[np.ndarray]:
        axes = [ax for ax in figures[name].axes if ax.get_title(loc="left").endswith(" B")]
        assert len(axes) == 1, name
        return [np.asarray(ln.get_xdata(), float) for ln in axes[0].get_lines()]

    for x in b_lines("position_errors"):
        x = x + run.time_origin_s - T0
        crosses = (x[:-1] < 90.0) & (x[1:] > 90.0)  # NaN compares False: a break
        assert np.isnan(x).any() and not crosses.any()
    assert all(np.isnan(x).any() for x in b_lines("trajectories") if x.size > 1)


def test_position_error_lines_break_at_gaps() -> None:
    t = np.r_[np.arange(0.0, 10.0, 1.0), np.arange(70.0, 80.0, 1.0)]
    rows = pd.DataFrame({"time": t, "method": "observed", "error_h": np.linspace(0, 1, t.size)})
    ax = Figure().add_subplot()
    plot_position_errors(ax, rows, methods=("observed",))
    (line,) = ax.get_lines()
    x = np.asarray(line.get_xdata(), float)
    assert x.size == t.size + 1 and np.isnan(x[10])
    np.testing.assert_array_equal(x[np.isfinite(x)], t)
