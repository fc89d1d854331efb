"""`coopproc batch` faults: a missing session, an unreachable scheduler, sessions of one
name, outputs that exist, a ROOT that cannot be made. One line each, checked before the
work where they can be.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import socket
import tempfile
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner, Result

import coopproc.run.batch
import coopproc.run.output
from coopproc.cli import main


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sessions") / "s1"
    res = CliRunner().invoke(
        main, ["simulate", str(path), "--scenario", "paper-experiment", "--duration", "60"]
    )
    assert res.exit_code == 0, res.output
    return path


def batch(*args: str | Path) -> Result:
    return CliRunner().invoke(
        main, ["batch", *map(str, args), "--threads", "-j", "1", "--no-figures"]
    )


def test_a_missing_session_is_one_failed_session_and_the_others_run(
    session: Path, tmp_path: Path
) -> None:
    missing = tmp_path / "nosuch"
    root = tmp_path / "root"
    res = batch(session, missing, "-o", root)
    assert res.exit_code == 1, res.output
    error = f"error: {missing}: no such file or directory; expected a session directory or .mcap"
    assert res.output.count("error:") == 1 and error in res.output
    assert "1 of 2 sessions processed" in res.output
    listing = json.loads((root / "batch.json").read_text())["sessions"]
    assert [(e["output"], e["ok"], e["status"]) for e in listing] == [
        ("nosuch", False, "failed"),
        ("s1", True, "processed"),
    ]
    assert listing[0]["error"] == error.removeprefix("error: ")
    assert set(pd.read_csv(root / "batch_metrics.csv")["session"]) == {"s1"}
    assert not (root / "nosuch").exists()


def test_a_session_given_twice_is_processed_once(session: Path, tmp_path: Path) -> None:
    root = tmp_path / "root"
    res = batch(session, session.parent / ".." / session.parent.name / "s1", "-o", root)
    assert res.exit_code == 0, res.output
    assert "1 of 1 sessions processed" in res.output
    listing = json.loads((root / "batch.json").read_text())["sessions"]
    assert [e["output"] for e in listing] == ["s1"]


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
    return port


def test_an_unreachable_scheduler_fails_at_once_naming_address_and_cause(
    session: Path, tmp_path: Path
) -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    root = tmp_path / "root"
    started = time.monotonic()
    res = CliRunner().invoke(main, ["batch", str(session), "-o", str(root), "--scheduler", address])
    assert time.monotonic() - started < 10
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: scheduler {address}: cannot connect (Connection refused); "
        "is a Dask scheduler running there?\n"
    )
    assert not root.exists()  # checked before any work


def test_something_else_at_the_address_is_no_scheduler(
    session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(coopproc.run.batch, "HANDSHAKE_TIMEOUT_S", 1.0)
    with socket.socket() as listener:  # accepts connections, never answers
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        res = CliRunner().invoke(
            main, ["batch", str(session), "-o", str(tmp_path / "r"), "--scheduler", address]
        )
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: scheduler {address}: something listens there but is no Dask scheduler "
        "(no reply within 1 s)\n"
    )


def test_a_running_scheduler_processes_the_sessions(session: Path, tmp_path: Path) -> None:
    from dask.distributed import LocalCluster

    root = tmp_path / "root"
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=None
    ) as cluster:
        worker = next(iter(cluster.scheduler_info["workers"]))
        res = CliRunner().invoke(
            main, ["batch", str(session), "-o", str(root), "--scheduler", worker]
        )
        assert res.exit_code == 1, res.output
        assert res.output == (
            f"error: scheduler {worker}: a Dask Worker answers there, not the scheduler\n"
        )
        address = cluster.scheduler_address
        res = CliRunner().invoke(
            main, ["batch", str(session), "-o", str(root), "--scheduler", address, "--no-figures"]
        )
    assert res.exit_code == 0, res.output
    assert "1 of 1 sessions processed" in res.output
    assert (root / "s1" / "run.json").is_file()


def test_a_scheduler_that_is_no_address_is_refused(session: Path, tmp_path: Path) -> None:
    res = CliRunner().invoke(
        main, ["batch", str(session), "-o", str(tmp_path / "r"), "--scheduler", "tcp://h:port"]
    )
    assert res.exit_code == 1, res.output
    assert res.output.startswith("error: scheduler tcp://h:port: not an address (")
    assert res.output.endswith("); expected tcp://host:port\n")


def test_two_sessions_of_one_name_are_refused_before_the_work(
    session: Path, tmp_path: Path
) -> None:
    other = tmp_path / "elsewhere" / "s1"
    shutil.copytree(session, other)
    root = tmp_path / "root"
    res = batch(session, other, "-o", root)
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: sessions {session} and {other} would both write {root}/s1/ (outputs are "
        "named after the session directory or .mcap file); rename one, or batch them into "
        "different ROOTs\n"
    )
    assert not root.exists()


def test_existing_outputs_need_resume_or_force(session: Path, tmp_path: Path) -> None:
    root = tmp_path / "root"
    assert batch(session, "-o", root).exit_code == 0
    before = (root / "s1" / "run.json").read_text()
    res = batch(session, "-o", root)
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: {root}: 1 of these sessions have outputs there already (s1); use --resume "
        "to skip the complete ones and redo the rest, or --force to replace them\n"
    )
    assert (root / "s1" / "run.json").read_text() == before
    res = batch(session, "-o", root, "--force")
    assert res.exit_code == 0, res.output
    assert (root / "s1" / "run.json").read_text() != before  # a new start time


def test_resume_leaves_a_directory_that_is_no_run_alone(session: Path, tmp_path: Path) -> None:
    root = tmp_path / "root"
    (root / "s1").mkdir(parents=True)
    (root / "s1" / "notes.txt").write_text("mine\n")
    res = batch(session, "-o", root, "--resume")
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: {root}/s1: exists and holds no coopproc run (no run.json); "
        "use --force to replace it\n"
    )
    assert (root / "s1" / "notes.txt").read_text() == "mine\n"


def test_a_root_that_cannot_be_made_is_one_line_before_the_work(
    session: Path, tmp_path: Path
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x\n")
    res = batch(session, "-o", afile / "sub")
    assert res.exit_code == 1, res.output
    assert res.output == f"error: {afile}/sub: cannot create the directory: {afile} is a file\n"
    res = batch(session, "-o", afile)
    assert res.exit_code == 1, res.output
    assert res.output == f"error: {afile}: exists and is not a directory\n"


def test_a_root_that_cannot_be_written_is_one_line_before_the_work(
    session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def read_only(*args: object, **kwargs: object) -> str:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(tempfile, "mkdtemp", read_only)  # the probe (root may write anywhere)
    res = batch(session, "-o", tmp_path / "root")
    assert res.exit_code == 1, res.output
    assert res.output == (
        f"error: {tmp_path}/root: cannot write the outputs there (Read-only file system)\n"
    )


def test_a_disk_that_fills_during_a_session_fails_that_session_in_one_line(
    session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full(*args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp_path / "x.csv"))

    monkeypatch.setattr(coopproc.run.output, "write_run", full)  # threads: the same process
    root = tmp_path / "root"
    res = batch(session, "-o", root)
    assert res.exit_code == 1, res.output
    error = f"error: {session}: {tmp_path}/x.csv: No space left on device"
    assert res.output.count("error:") == 1 and error in res.output
    entries = json.loads((root / "batch.json").read_text())["sessions"]
    assert entries[0]["error"] == error.removeprefix("error: ")
    assert not (root / "batch_metrics.csv").exists()
