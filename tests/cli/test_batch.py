"""`coopproc batch`: several sessions on a local Dask cluster, one failing."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from coopproc.cli import main


def test_batch_runs_each_session_like_run_and_reports_failures(tmp_path: Path) -> None:
    runner = CliRunner()
    sessions = []
    for seed in (3, 4):
        path = tmp_path / f"s{seed}"
        res = runner.invoke(
            main,
            [
                "simulate",
                str(path),
                "--scenario",
                "paper-table1",
                "--seed",
                str(seed),
                "--duration",
                "40",
            ],
        )
        assert res.exit_code == 0, res.output
        sessions.append(path)
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "ranges.csv").write_text("time,from,to,range\n1.0,A,B,-3\n")
    root = tmp_path / "batch"
    res = runner.invoke(
        main,
        [
            "batch",
            *map(str, sessions),
            str(broken),
            "-o",
            str(root),
            "--threads",
            "-j",
            "2",
            "--no-figures",
        ],
    )
    assert res.exit_code == 1, res.output
    assert "2 of 3 sessions processed" in res.output
    # the failure is printed once (stderr is no terminal here), naming the file and line
    error = f"error: {broken}/ranges.csv:2: range -3.0 m is negative; expected 0..2000 m"
    assert res.output.count("error:") == 1 and error in res.output
    listing = json.loads((root / "batch.json").read_text())["sessions"]
    # sorted by output name; the session as its absolute path
    assert [(s["output"], s["ok"], s["status"]) for s in listing] == [
        ("broken", False, "failed"),
        ("s3", True, "processed"),
        ("s4", True, "processed"),
    ]
    assert listing[0]["session"] == str(broken.resolve())
    assert listing[0]["error"] == error.removeprefix("error: ")
    stacked = pd.read_csv(root / "batch_metrics.csv")
    assert stacked.columns[0] == "session"
    assert set(stacked["session"]) == {"s3", "s4"}
    # each session's tables are exactly those `coopproc run` writes
    single = tmp_path / "single"
    res = runner.invoke(main, ["run", str(sessions[0]), "-o", str(single), "--no-figures"])
    assert res.exit_code == 0, res.output
    for name in ("ranges.csv", "metrics.csv", "positions.csv"):
        assert (root / "s3" / name).read_bytes() == (single / name).read_bytes()
