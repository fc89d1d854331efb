"""`coopproc batch --resume`, and batch.json / the stacked tables describing every session
under ROOT across calls.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result

from coopproc.cli import main
from coopproc.run.batch_root import stale_reason
from coopproc.run.config import RunConfig


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two simulated sessions s1, s2 and a broken one, in one directory."""
    base = tmp_path_factory.mktemp("sessions")
    for name, seed in (("s1", "1"), ("s2", "2")):
        res = CliRunner().invoke(
            main,
            [
                *("simulate", str(base / name), "--scenario", "paper-experiment"),
                *("--duration", "60", "--seed", seed),
            ],
        )
        assert res.exit_code == 0, res.output
    (base / "broken").mkdir()
    (base / "broken" / "ranges.csv").write_text("time,from,to,range\n1.0,A,B,-3\n")
    return base


@pytest.fixture
def sessions(made: Path, tmp_path: Path) -> Path:
    """A copy of the sessions this test may change."""
    shutil.copytree(made, tmp_path / "sessions")
    return tmp_path / "sessions"


def batch(*args: str | Path) -> Result:
    return CliRunner().invoke(
        main, ["batch", *map(str, args), "--threads", "-j", "1", "--no-figures"]
    )


def listing(root: Path) -> list[tuple[str, bool, str]]:
    entries = json.loads((root / "batch.json").read_text())["sessions"]
    return [(e["output"], e["ok"], e["status"]) for e in entries]


def start(root: Path, name: str) -> Any:
    return json.loads((root / name / "run.json").read_text())["start_time"]


@pytest.mark.slow
def test_resume_skips_current_runs_and_redoes_changed_and_failed_ones(
    sessions: Path, tmp_path: Path
) -> None:
    s1, s2, broken = sessions / "s1", sessions / "s2", sessions / "broken"
    root = tmp_path / "root"
    assert batch(s1, s2, broken, "-o", root).exit_code == 1
    started = {n: start(root, n) for n in ("s1", "s2")}
    # nothing changed: both runs kept, the failure retried (and printed once)
    res = batch(s1, s2, broken, "-o", root, "--resume")
    assert res.exit_code == 1, res.output
    assert res.output.count("error:") == 1 and f"error: {broken}/ranges.csv:2:" in res.output
    assert "0 of 1 sessions processed into" in res.output
    assert "; 2 skipped (complete and current)" in res.output
    assert {n: start(root, n) for n in ("s1", "s2")} == started
    assert listing(root) == [
        ("broken", False, "failed"),
        ("s1", True, "skipped"),
        ("s2", True, "skipped"),
    ]
    # a changed input: that session is redone, the other kept
    ranges = s2 / "ranges.csv"
    ranges.write_text(ranges.read_text().replace(",", ", ", 1))
    res = batch(s1, s2, "-o", root, "--resume")
    assert res.exit_code == 0, res.output
    assert "1 of 1 sessions processed into" in res.output
    assert start(root, "s1") == started["s1"]
    assert listing(root) == [
        ("broken", False, "earlier"),
        ("s1", True, "skipped"),
        ("s2", True, "processed"),
    ]
    # an incomplete run is redone
    (root / "s1" / "positions.csv").unlink()
    res = batch(s1, "-o", root, "--resume")
    assert res.exit_code == 0, res.output
    assert (root / "s1" / "positions.csv").is_file()


def test_resume_refuses_the_run_of_another_session_of_that_name(
    sessions: Path, tmp_path: Path
) -> None:
    root = tmp_path / "root"
    assert batch(sessions / "s1", "-o", root).exit_code == 0
    other = tmp_path / "other" / "s1"
    shutil.copytree(sessions / "s2", other)
    res = batch(other, "-o", root, "--resume")
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: {root}/s1: holds the run of {sessions / 's1'}, not of {other} (outputs are "
        "named after the session directory); batch it into another ROOT, or use --force to "
        "replace it\n"
    )


@pytest.mark.slow
def test_batch_json_and_the_stacked_tables_describe_every_session_under_root(
    sessions: Path, tmp_path: Path
) -> None:
    s1, s2, broken = sessions / "s1", sessions / "s2", sessions / "broken"
    root = tmp_path / "root"
    assert batch(s1, broken, "-o", root).exit_code == 1
    # a later call with another session: the earlier run and failure stay listed
    res = batch(s2, "-o", root)
    assert res.exit_code == 0, res.output  # an earlier failure does not fail this call
    assert f"{root}/batch.json: 3 sessions, 2 ok, 1 failed" in res.output
    assert listing(root) == [
        ("broken", False, "earlier"),
        ("s1", True, "earlier"),
        ("s2", True, "processed"),
    ]
    entries = json.loads((root / "batch.json").read_text())["sessions"]
    assert entries[0]["error"].startswith(f"{broken}/ranges.csv:2: range -3.0 m is negative")
    assert entries[1]["session"] == str(s1)
    assert entries[1]["time"] == start(root, "s1")
    for stacked, table in (
        ("batch_metrics.csv", "metrics.csv"),
        ("batch_position_metrics.csv", "position_metrics.csv"),
    ):
        # each ok session's table as written, cell for cell, after its name
        rows = (root / stacked).read_text().splitlines()
        header, *want = (root / "s1" / table).read_text().splitlines()
        assert rows[0] == f"session,{header}"
        want = [f"s1,{r}" for r in want]
        want += [f"s2,{r}" for r in (root / "s2" / table).read_text().splitlines()[1:]]
        assert rows[1:] == want
    # the failed session fixed: its earlier failure is replaced
    shutil.rmtree(broken)
    shutil.copytree(s2, broken)
    assert batch(broken, "-o", root).exit_code == 0
    assert listing(root) == [
        ("broken", True, "processed"),
        ("s1", True, "earlier"),
        ("s2", True, "earlier"),
    ]


@pytest.mark.slow
def test_a_failed_rerun_outdates_the_run_it_left_in_place(sessions: Path, tmp_path: Path) -> None:
    s1, s2 = sessions / "s1", sessions / "s2"
    root = tmp_path / "root"
    assert batch(s1, s2, "-o", root).exit_code == 0
    (s1 / "ranges.csv").write_text("time,from,to,range\n1.0,A,B,-3\n")
    res = batch(s1, "-o", root, "--force")
    assert res.exit_code == 1, res.output
    assert (root / "s1" / "run.json").is_file()  # the old run stays (atomic output) ...
    for call in ("this", "a later"):  # ... but is listed as failed, and not stacked
        assert listing(root)[0] == ("s1", False, "failed" if call == "this" else "earlier")
        assert not (root / "batch_metrics.csv").read_text().count("\ns1,")
        assert batch(s2, "-o", root, "--force").exit_code == 0


def test_stale_reason_names_what_makes_a_run_not_current(sessions: Path, tmp_path: Path) -> None:
    s1 = sessions / "s1"
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(s1), "-o", str(out), "--no-figures", "-q"])
    assert res.exit_code == 0, res.output
    config = RunConfig()
    config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
    assert stale_reason(out, s1, config) is None
    # the scores of an injected session follow its injected.csv
    (s1 / "injected.csv").write_text("time,pair,kind,error,event,start,end,mean,sd\n")
    assert stale_reason(out, s1, config) == "new input injected.csv"
    (s1 / "injected.csv").unlink()
    assert stale_reason(out, s1, config) is None
    assert stale_reason(out, s1, RunConfig()) == "another configuration"
    (s1 / "nav_A.csv").write_text((s1 / "nav_A.csv").read_text() + "\n")
    assert stale_reason(out, s1, config) == "input nav_A.csv changed"
    shutil.copy(s1 / "nav_C.csv", s1 / "nav_D.csv")
    assert stale_reason(out, s1, config) == "new input nav_D.csv"
    (s1 / "nav_D.csv").unlink()
    (s1 / "ref_C.pos").unlink()
    assert stale_reason(out, s1, config) == "input ref_C.pos gone"
    (out / "metrics.csv").unlink()
    assert stale_reason(out, s1, config) == "incomplete run (metrics.csv missing)"
    (out / "run.json").write_text("{")
    assert stale_reason(out, s1, config) == "incomplete run (no readable run.json)"
