"""The frame check: a platform navigating in a frame of its own is named, with the fitted
rotation and shift; drifting dead reckoning in the session frame is not."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.checks.framecheck import fit_frame, frame_notes
from coopproc.cli import main
from coopproc.io import read_session

REPO = Path(__file__).resolve().parents[2]
NOTE = re.compile(
    r"(?P<pid>\w+)'s navigation looks like it is in a frame of its own: its ranges to "
    r"(?P<partners>[\w, ]+) fit (?P<after>[\d.]+) m RMS instead of (?P<before>[\d.]+) m once "
    r"its track is rotated by (?P<rot>-?[\d.]+) deg and shifted by (?P<shift>[\d.]+) m "
    r"\(east (?P<east>-?[\d.]+), north (?P<north>-?[\d.]+), at its centroid\), so the fused "
    r"results are not meaningful; for a platform that knows only its own motion use "
    r"coopproc locate (?P<session>\S+) --target (?P<target>\w+) --aux (?P<aux>[\w,]+)$"
)


@pytest.fixture(scope="module")
def single_aux(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("frame") / "sa"
    res = CliRunner().invoke(main, ["simulate", str(path), "--scenario", "single-auxiliary"])
    assert res.exit_code == 0, res.output
    return path


def _angle(deg: float) -> float:
    return (deg + 180.0) % 360.0 - 180.0


def test_single_auxiliary_target_is_named_by_validate_and_run(
    single_aux: Path, tmp_path: Path
) -> None:
    res = CliRunner().invoke(main, ["validate", str(single_aux)])
    assert res.exit_code == 0
    lines = res.output.splitlines()
    # the readers' notes (reference epochs dropped) first, then the frame note
    lines = [line for line in lines if "dropped from the reference" not in line]
    assert len(lines) == 2 and lines[1] == f"{single_aux}: ok"
    assert lines[0].startswith("note: ")
    m = NOTE.match(lines[0].removeprefix("note: "))
    assert m, lines[0]
    assert (m["pid"], m["partners"], m["target"], m["aux"]) == ("T", "A1", "T", "A1")
    assert m["session"] == str(single_aux)
    fit = fit_frame(read_session(single_aux), "T")
    assert fit is not None and fit.fires
    # the numbers printed are the fit's
    assert float(m["rot"]) == round(fit.rotation_deg, 1)
    assert float(m["shift"]) == round(fit.shift_m, 1)
    assert float(m["after"]) == round(fit.rms_after_m, 2)
    assert float(m["before"]) == round(fit.rms_before_m, 2)
    assert fit.rms_after_m < 0.2 < 10.0 < fit.rms_before_m
    # and the rotation is the one the simulator applied (own frame -> session frame)
    truth = pd.read_csv(single_aux / "truth" / "nav_frames.csv").set_index("platform")
    assert _angle(fit.rotation_deg + truth.loc["T", "rotation_deg"]) == pytest.approx(0, abs=1.0)

    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(single_aux), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    note = lines[0].removeprefix("note: ")
    assert res.output.count(f"note: {note}\n") == 1
    assert json.loads((out / "run.json").read_text())["notes"][-1] == note


def test_rotated_and_shifted_nav_is_found(tmp_path: Path) -> None:
    session = tmp_path / "s"
    shutil.copytree(REPO / "sample_logs", session, ignore=shutil.ignore_patterns("mcap"))
    nav = pd.read_csv(session / "nav_C.csv", comment="#")
    theta = np.radians(30.0)
    east, north = nav["east"].to_numpy(), nav["north"].to_numpy()
    nav["east"] = np.cos(theta) * east - np.sin(theta) * north + 15.0
    nav["north"] = np.sin(theta) * east + np.cos(theta) * north - 5.0
    nav.to_csv(session / "nav_C.csv", index=False, float_format="%.6f")
    notes = frame_notes(read_session(session))
    assert len(notes) == 1
    m = NOTE.match(notes[0])
    assert m, notes[0]
    assert (m["pid"], m["partners"], m["aux"]) == ("C", "A, B", "A,B")
    assert float(m["rot"]) == pytest.approx(-30.0, abs=0.3)
    # the centroid moves back to where the session frame has it
    shift = np.array([east.mean() - nav["east"].mean(), north.mean() - nav["north"].mean()])
    assert (float(m["east"]), float(m["north"])) == pytest.approx(tuple(shift), abs=0.5)
    assert float(m["after"]) < 0.3


def test_session_frame_navigation_is_not_flagged() -> None:
    assert frame_notes(read_session(REPO / "sample_logs")) == []


@pytest.mark.parametrize("name", ["tiers", "tuc"])
def test_real_drifting_navigation_is_not_flagged(name: str) -> None:
    path = REPO / ".." / "shared" / "data" / "real" / name
    if not (path / "session.toml").is_file():
        pytest.skip("shared/data/real is not present")
    session = read_session(path)
    assert frame_notes(session) == []
    for pid in session.moving_platforms():
        fit = fit_frame(session, pid)
        assert fit is not None and fit.gain < 2.5  # far from the 3x threshold
