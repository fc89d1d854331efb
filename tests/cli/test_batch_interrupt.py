"""Ctrl-C in `coopproc batch` (issue 32): one line, no Dask traceback, nothing half-made;
and one line per session as it finishes."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.run.batch_interrupt import clean_after_interrupt


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("sessions")
    out = []
    for seed in (5, 6):
        path = root / f"s{seed}"
        args = ["simulate", str(path), "--scenario", "paper-table1", "--seed", str(seed)]
        res = CliRunner().invoke(main, [*args, "--duration", "30"])
        assert res.exit_code == 0, res.output
        out.append(path)
    return out


@pytest.mark.slow
def test_ctrl_c_after_the_first_session_is_one_line_and_leaves_whole_outputs(
    sessions: list[Path], tmp_path: Path
) -> None:
    """SIGINT to the process group (what a terminal's Ctrl-C sends) once the first
    session is done: exit 130, the progress line and the interrupted line and nothing
    else (no Dask log line, no traceback), the finished session listed in batch.json,
    no temporary directory left."""
    root = tmp_path / "root"
    command = [sys.executable, "-m", "coopproc", "batch", *map(str, sessions), "-o", str(root)]
    proc = subprocess.Popen(
        [*command, "--no-figures", "-j", "1"],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    assert proc.stderr is not None
    lines = []
    for line in proc.stderr:
        lines.append(line.rstrip("\n"))
        if " done (" in line:
            os.killpg(proc.pid, signal.SIGINT)
            break
    lines += proc.stderr.read().splitlines()
    assert proc.wait(timeout=120) == 130
    assert lines[0].startswith("batch: s5 done (1 of 2, ")
    assert len(lines) == 2, lines
    assert lines[1].startswith("interrupted: ")
    assert f"sessions processed into {root}/ (s5" in lines[1]
    assert "Traceback" not in "\n".join(lines)
    listed = {s["output"] for s in json.loads((root / "batch.json").read_text())["sessions"]}
    assert "s5" in listed and (root / "s5" / "run.json").is_file()
    assert [p.name for p in root.iterdir() if p.name.endswith(".tmp")] == []


def test_the_cleanup_removes_temporary_outputs_and_an_empty_root_it_made(tmp_path: Path) -> None:
    root = tmp_path / "root"
    (root / ".s1.abc123.tmp" / "figures").mkdir(parents=True)
    (root / ".s1.abc123.tmp" / "ranges.csv").write_text("half\n")
    clean_after_interrupt(root, ["s1"], made_root=True)
    assert not root.exists()
    (root / ".s2.x.tmp").mkdir(parents=True)
    (root / "other").mkdir()
    clean_after_interrupt(root, ["s2"], made_root=True)  # not empty: kept
    assert sorted(p.name for p in root.iterdir()) == ["other"]
    clean_after_interrupt(root, [], made_root=False)
    assert root.is_dir()


def test_each_finished_session_is_one_line(sessions: list[Path], tmp_path: Path) -> None:
    root = tmp_path / "root"
    res = CliRunner().invoke(
        main, ["batch", *map(str, sessions), "-o", str(root), "--threads", "--no-figures"]
    )
    assert res.exit_code == 0, res.output
    done = sorted(line.split(" (")[0] for line in res.output.splitlines() if " done (" in line)
    assert done == ["batch: s5 done", "batch: s6 done"]
    assert sum(" of 2, " in line for line in res.output.splitlines()) == 2


def test_a_taken_dask_port_prints_nothing(sessions: list[Path], tmp_path: Path) -> None:
    """Dask's default port 8787 in use (a user's dashboard, another cluster): the batch's
    local cluster takes a free port and prints no "Port 8787 is already in use" warning
    (it did: the slow suite's Ctrl-C test read it as its first line)."""
    with socket.socket() as taken:
        with contextlib.suppress(OSError):  # already taken by someone else: the same case
            taken.bind(("", 8787))
        taken.listen()
        res = subprocess.run(
            [sys.executable, "-m", "coopproc", "batch", str(sessions[0]), "-o",
             str(tmp_path / "root"), "--no-figures", "-j", "1"],
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "8787" not in res.stderr and "Warning" not in res.stderr, res.stderr
    assert res.stderr.splitlines()[0].startswith("batch: s5 done (1 of 1, ")
