"""File-system faults end in one line naming the path and the cause (issue 16, item 1).

A read-only file system, a directory that cannot be written, a path under a file, a
missing directory and a full disk: exit status 1, one ``error:`` line, no traceback, no
half-written output, and the output place checked before the work where it can be.

Tests may run as root, where ``chmod 0o555`` does not stop writes: there, and for a
read-only file system (which a test cannot mount), the refusal is simulated by making
``os.mkdir`` / ``os.open`` raise the operating system's error for paths in that directory.
"""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result

import coopproc.io
import coopproc.run.output
from coopproc.cli import main
from coopproc.io.outdir import write_csv

ROFS = os.strerror(errno.EROFS)  # "Read-only file system"
EACCES = os.strerror(errno.EACCES)  # "Permission denied"
ENOSPC = os.strerror(errno.ENOSPC)  # "No space left on device"


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("fs") / "session"
    res = CliRunner().invoke(
        main, ["simulate", str(path), "--scenario", "paper-table1", "--duration", "60"]
    )
    assert res.exit_code == 0, res.output
    return path


@pytest.fixture(scope="module")
def finished_run(session: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fs-run") / "out"
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures", "-q"])
    assert res.exit_code == 0, res.output
    return out


def _cli(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def _one_error_line(res: Result, expected: str) -> None:
    """Exit status 1 and ``error: expected`` as the one line on stderr; nothing else."""
    assert res.exit_code == 1, res.output
    assert res.stderr == f"error: {expected}\n"
    assert res.stdout == ""
    assert "Traceback" not in res.output


def _refuse_writes(monkeypatch: pytest.MonkeyPatch, directory: Path, code: int) -> None:
    """Make creating anything in ``directory`` fail with ``code`` (EROFS, EACCES, ...)."""
    real_mkdir, real_open = os.mkdir, os.open
    inside = str(directory.resolve())

    def refused(path: Any) -> bool:
        return os.path.abspath(os.fspath(path)).startswith(inside)

    def mkdir(path: Any, *args: Any, **kwargs: Any) -> None:
        if refused(path):
            raise OSError(code, os.strerror(code), os.fspath(path))
        real_mkdir(path, *args, **kwargs)

    def open_(path: Any, flags: int, *args: Any, **kwargs: Any) -> int:
        if refused(path) and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise OSError(code, os.strerror(code), os.fspath(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "mkdir", mkdir)
    monkeypatch.setattr(os, "open", open_)


def _writes_allowed(directory: Path) -> bool:
    try:
        probe = tempfile.mkdtemp(dir=directory)
    except PermissionError:
        return False
    os.rmdir(probe)
    return True


@pytest.fixture
def read_only_fs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A directory on a (simulated) read-only file system."""
    directory = tmp_path / "ro"
    directory.mkdir()
    _refuse_writes(monkeypatch, directory, errno.EROFS)
    return directory


@pytest.fixture
def locked_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A directory without write permission (chmod 0o555; simulated as well for root)."""
    directory = tmp_path / "locked"
    directory.mkdir()
    directory.chmod(0o555)
    if _writes_allowed(directory):  # root: permissions do not stop it
        _refuse_writes(monkeypatch, directory, errno.EACCES)
    yield directory
    directory.chmod(0o755)


@pytest.fixture
def no_work(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if a command reads its session (the check must come first)."""

    def read_session(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the session was read before the output was checked")

    monkeypatch.setattr(coopproc.io, "read_session", read_session)


def _leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


# --- run and locate: the output directory -------------------------------------------


@pytest.mark.usefixtures("no_work")
def test_run_on_read_only_file_system_fails_before_the_work(
    session: Path, read_only_fs: Path
) -> None:
    out = read_only_fs / "out"
    res = _cli("run", str(session), "-o", str(out), "--no-figures")
    _one_error_line(res, f"{out}: cannot write in {read_only_fs} ({ROFS})")
    assert _leftovers(read_only_fs) == []


@pytest.mark.usefixtures("no_work")
def test_run_into_unwritable_directory_fails_before_the_work(
    session: Path, locked_dir: Path
) -> None:
    out = locked_dir / "out"
    res = _cli("run", str(session), "-o", str(out), "--no-figures")
    _one_error_line(res, f"{out}: cannot write in {locked_dir} ({EACCES})")
    assert _leftovers(locked_dir) == []


@pytest.mark.usefixtures("no_work")
def test_run_under_a_missing_directory_of_a_read_only_one(
    session: Path, read_only_fs: Path
) -> None:
    out = read_only_fs / "new" / "out"
    res = _cli("run", str(session), "-o", str(out))
    _one_error_line(res, f"{out}: cannot write in {read_only_fs} ({ROFS})")
    assert _leftovers(read_only_fs) == []


@pytest.mark.usefixtures("no_work")
@pytest.mark.parametrize("below", ["sub", "sub/deeper"])
def test_run_under_a_file(session: Path, tmp_path: Path, below: str) -> None:
    afile = tmp_path / "afile"
    afile.write_text("not a directory")
    out = afile / below
    res = _cli("run", str(session), "-o", str(out), "--no-figures")
    _one_error_line(res, f"{out}: cannot create the output: {afile} is not a directory")
    assert afile.read_text() == "not a directory"


@pytest.mark.usefixtures("no_work")
def test_run_onto_a_file(session: Path, tmp_path: Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("not a directory")
    res = _cli("run", str(session), "-o", str(afile), "--force")
    _one_error_line(res, f"{afile}: exists and is not a directory")


def test_run_creates_missing_parent_directories(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "new" / "deeper" / "out"
    res = _cli("run", str(session), "-o", str(out), "--no-figures", "-q")
    assert res.exit_code == 0, res.output
    assert (out / "metrics.csv").is_file()


def _disk_full_after(calls: int) -> Callable[..., Path]:
    """write_csv that writes ``calls`` tables, then half of one, then finds the disk full."""
    count = 0

    def write(frame: Any, path: Path, columns: Any = None) -> Path:
        nonlocal count
        count += 1
        written = write_csv(frame, path, columns)
        if count > calls:
            data = written.read_bytes()
            written.write_bytes(data[: len(data) // 2])
            raise OSError(errno.ENOSPC, ENOSPC)
        return written

    return write


def test_run_disk_full_leaves_nothing_half_written(
    session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(coopproc.run.output, "write_csv", _disk_full_after(2))
    out = tmp_path / "out"
    res = _cli("run", str(session), "-o", str(out), "--no-figures", "-q")
    _one_error_line(res, f"{out}: cannot write the output ({ENOSPC}); nothing was written")
    assert _leftovers(tmp_path) == []


def test_run_disk_full_keeps_the_previous_output(
    session: Path, finished_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    res = _cli("run", str(session), "-o", str(out), "--no-figures", "-q")
    assert res.exit_code == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    monkeypatch.setattr(coopproc.run.output, "write_csv", _disk_full_after(0))
    res = _cli("run", str(session), "-o", str(out), "--no-figures", "-q", "--force")
    _one_error_line(
        res, f"{out}: cannot write the output ({ENOSPC}); the existing output is unchanged"
    )
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _leftovers(tmp_path) == ["out"]


def test_debug_shows_the_traceback(session: Path, tmp_path: Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("")
    res = _cli("--debug", "run", str(session), "-o", str(afile / "sub"))
    assert res.exit_code == 1
    assert type(res.exception).__name__ == "OutputError"
    assert "is not a directory" in str(res.exception)


@pytest.mark.usefixtures("no_work")
def test_locate_on_read_only_file_system_fails_before_the_work(
    session: Path, read_only_fs: Path
) -> None:
    out = read_only_fs / "loc"
    res = _cli("locate", str(session), "--target", "A", "--aux", "B", "-o", str(out))
    _one_error_line(res, f"{out}: cannot write in {read_only_fs} ({ROFS})")
    assert _leftovers(read_only_fs) == []


@pytest.mark.usefixtures("no_work")
def test_locate_under_a_file(session: Path, tmp_path: Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("")
    out = afile / "loc"
    res = _cli("locate", str(session), "--target", "A", "--aux", "B", "-o", str(out))
    _one_error_line(res, f"{out}: cannot create the output: {afile} is not a directory")


def test_simulate_on_read_only_file_system(read_only_fs: Path) -> None:
    out = read_only_fs / "sim"
    res = _cli("simulate", str(out), "--scenario", "paper-table1", "--duration", "60")
    _one_error_line(res, f"{out}: cannot write in {read_only_fs} ({ROFS})")


# --- report: -o FILE and figures into OUT ---------------------------------------------


def test_report_into_a_missing_directory(
    finished_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    res = _cli("report", str(finished_run), "--format", "latex", "-o", "missing_dir/t.tex")
    _one_error_line(res, "missing_dir/t.tex: cannot write: directory missing_dir does not exist")
    assert _leftovers(tmp_path) == []


def test_report_under_a_file(finished_run: Path, tmp_path: Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("")
    target = afile / "t.tex"
    res = _cli("report", str(finished_run), "--format", "latex", "-o", str(target))
    _one_error_line(res, f"{target}: cannot write: {afile} is not a directory")


def test_report_into_read_only_file_system(finished_run: Path, read_only_fs: Path) -> None:
    target = read_only_fs / "t.tex"
    res = _cli("report", str(finished_run), "--format", "md", "-o", str(target))
    _one_error_line(res, f"{target}: cannot write in {read_only_fs} ({ROFS})")
    assert _leftovers(read_only_fs) == []


def test_report_into_unwritable_directory(finished_run: Path, locked_dir: Path) -> None:
    target = locked_dir / "t.tex"
    res = _cli("report", str(finished_run), "--format", "csv", "-o", str(target))
    _one_error_line(res, f"{target}: cannot write in {locked_dir} ({EACCES})")


class _FullDisk:
    """``open`` for a text file whose write stores part of the text, then finds the disk
    full (closed by the ``with`` block that uses it)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._handle = open(*args, **kwargs)  # noqa: SIM115

    def __enter__(self) -> _FullDisk:
        return self

    def __exit__(self, *exc: object) -> None:
        self._handle.close()

    def write(self, text: str) -> int:
        self._handle.write(text[: len(text) // 2])
        self._handle.flush()
        raise OSError(errno.ENOSPC, ENOSPC)


@pytest.mark.parametrize("existing", [False, True])
def test_report_disk_full_leaves_no_partial_file(
    finished_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, existing: bool
) -> None:
    import coopproc.io.outdir

    target = tmp_path / "t.tex"
    if existing:
        target.write_text("previous table\n")
    monkeypatch.setattr(coopproc.io.outdir, "open", _FullDisk, raising=False)
    res = _cli("report", str(finished_run), "--format", "latex", "-o", str(target))
    left = "the existing file is unchanged" if existing else "nothing was written"
    _one_error_line(res, f"{target}: cannot write ({ENOSPC}); {left}")
    if existing:
        assert target.read_text() == "previous table\n"
        assert _leftovers(tmp_path) == ["t.tex"]
    else:
        assert _leftovers(tmp_path) == []


def test_report_writes_the_file_whole(finished_run: Path, tmp_path: Path) -> None:
    target = tmp_path / "t.tex"
    res = _cli("report", str(finished_run), "--format", "latex", "-o", str(target))
    assert res.exit_code == 0, res.output
    assert res.stdout == f"wrote {target}\n"
    shown = _cli("report", str(finished_run), "--format", "latex").stdout
    assert target.read_text(encoding="utf-8") == shown and "\\begin{table}" in shown
    assert _leftovers(tmp_path) == ["t.tex"]


def test_report_figures_into_a_read_only_run(
    finished_run: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _refuse_writes(monkeypatch, finished_run, errno.EROFS)
    for option in ("--plots", "--html"):
        res = _cli("report", str(finished_run), option)
        _one_error_line(res, f"{finished_run}: cannot write ({ROFS})")
