"""Atomic output directories and files, and deterministic CSV writing.

Outputs are written into a temporary sibling directory (or file) and renamed into place
only when complete, so a crash or a full disk never leaves a half-written output. An
existing output directory is not replaced unless ``force`` is given; it is never a
directory holding session inputs.

Every file-system fault becomes one :class:`~coopproc.errors.OutputError` line naming the
path and the cause (``out: cannot create the output in /data (Read-only file system)``),
and the checks that can be made before the work (the place is a directory, it can be
written) are made by :func:`check_output_dir` and :func:`check_output_file`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from coopproc.errors import OutputError

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "atomic_output_dir",
    "check_output_dir",
    "check_output_file",
    "check_writable_dir",
    "columns_first",
    "csv_text",
    "output_errors",
    "write_csv",
    "write_text_atomic",
]

#: Float format of every output CSV: enough digits for millimetres on any time base, and
#: the same bytes for the same numbers (determinism).
FLOAT_FORMAT = "%.6f"


def _cause(err: OSError) -> str:
    """The operating system's words for ``err`` ("Read-only file system", ...)."""
    if err.strerror:
        return err.strerror
    return os.strerror(err.errno) if err.errno else str(err) or type(err).__name__


def _nearest_existing(path: Path) -> Path:
    """The nearest ancestor of ``path`` that exists, absolute (for the messages)."""
    for parent in path.absolute().parents:
        if os.path.lexists(parent):
            return parent
    return Path(path.absolute().anchor)


def check_writable_dir(directory: str | Path, what: str | Path) -> None:
    """Raise OutputError unless a file can be created in the existing ``directory``.

    Tried for real (a probe directory made and removed), as permissions alone do not
    tell a read-only file system, nor what root may do. ``what``: the output named in
    the message.
    """
    try:
        probe = tempfile.mkdtemp(prefix=".coopproc-probe.", dir=directory)
    except OSError as err:
        where = "" if Path(what) == Path(directory) else f" in {Path(directory).absolute()}"
        raise OutputError(f"{what}: cannot write{where} ({_cause(err)})") from err
    os.rmdir(probe)


def check_output_dir(
    path: str | Path, *, force: bool = False, protect: Sequence[Path] = ()
) -> Path:
    """Raise OutputError now if ``path`` cannot be the output (see atomic_output_dir).

    Called before long work so that a user learns at once of an existing directory, a
    path under a file, or a place that cannot be written. Missing parent directories are
    fine (they are created) if the nearest existing one can be written.
    """
    target = Path(path).resolve()
    for item in protect:
        p = Path(item).resolve()
        if target == p or p.is_relative_to(target):
            raise OutputError(f"{path}: refusing to write output over the input {item}")
    if target.exists() and not target.is_dir():
        raise OutputError(f"{path}: exists and is not a directory")
    if target.exists() and any(target.iterdir()) and not force:
        raise OutputError(f"{path}: output directory exists; use --force to replace it")
    base = _nearest_existing(Path(path))
    if not os.path.isdir(base):
        raise OutputError(f"{path}: cannot create the output: {base} is not a directory")
    check_writable_dir(base, path)
    return target


def check_output_file(path: str | Path) -> Path:
    """Raise OutputError now if the file ``path`` cannot be written (see write_text_atomic).

    Its directory must exist (it is not created: a mistyped directory is more likely
    than a wanted new one) and be writable; ``path`` must not be a directory.
    """
    p = Path(path)
    parent = p.parent
    if os.path.isdir(p):
        raise OutputError(f"{path}: is a directory; expected a file name")
    if not os.path.isdir(parent):
        base = _nearest_existing(p)
        if not os.path.isdir(base):
            raise OutputError(f"{path}: cannot write: {base} is not a directory")
        raise OutputError(f"{path}: cannot write: directory {parent} does not exist")
    check_writable_dir(parent, path)
    return p


@contextlib.contextmanager
def output_errors(what: str | Path) -> Iterator[None]:
    """Turn an OSError raised in the block into one OutputError line naming ``what``.

    For outputs written in place (figures remade into an existing run directory).
    """
    try:
        yield
    except OSError as err:
        name = f" {err.filename}" if err.filename else ""
        raise OutputError(f"{what}: cannot write{name} ({_cause(err)})") from err


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file renamed into place.

    A failure (full disk, ...) is an OutputError and leaves ``path`` as it was.
    """
    p = check_output_file(path)
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    except OSError as err:
        raise OutputError(f"{path}: cannot write ({_cause(err)})") from err
    tmp = Path(tmp_name)
    try:
        with open(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, p)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        left = "the existing file is unchanged" if p.exists() else "nothing was written"
        raise OutputError(f"{path}: cannot write ({_cause(err)}); {left}") from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return p


@contextlib.contextmanager
def atomic_output_dir(
    path: str | Path, *, force: bool = False, protect: Sequence[Path] = ()
) -> Iterator[Path]:
    """Yield a temporary directory that becomes ``path`` when the block ends without error.

    ``protect``: input paths that must never be overwritten or deleted (a run into the
    session directory itself is refused). An OSError in the block (a full disk, ...)
    removes the temporary directory, leaves ``path`` as it was, and is raised as one
    OutputError line.
    """
    target = check_output_dir(path, force=force, protect=protect)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    except OSError as err:
        raise OutputError(f"{path}: cannot write in {target.parent} ({_cause(err)})") from err
    existed = target.exists()
    try:
        yield tmp
        os.chmod(tmp, 0o755)
        _replace_dir(tmp, target)
    except OSError as err:
        shutil.rmtree(tmp, ignore_errors=True)
        raise OutputError(_write_failure(path, tmp, err, existed)) from err
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _replace_dir(tmp: Path, target: Path) -> None:
    """Rename ``tmp`` to ``target``, replacing an existing ``target`` (restored on failure)."""
    if not target.exists():
        tmp.rename(target)
        return
    old = target.with_name(f".{target.name}.old-{os.getpid()}")
    target.rename(old)
    try:
        tmp.rename(target)
    except OSError:
        old.rename(target)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _write_failure(path: str | Path, tmp: Path, err: OSError, existed: bool) -> str:
    what = "the output"
    if err.filename:
        try:
            what = str(Path(err.filename).relative_to(tmp))
        except ValueError:
            what = str(err.filename)
    left = "the existing output is unchanged" if existed else "nothing was written"
    return f"{path}: cannot write {what} ({_cause(err)}); {left}"


def columns_first(frame: pd.DataFrame, path: Path, columns: Sequence[str] | None) -> pd.DataFrame:
    """``frame`` with ``columns`` first, in that order, then the others; an OutputError
    naming ``path`` when one is missing."""
    if columns is None:
        return frame
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise OutputError(f"{path.name}: missing columns {missing}")
    extra = [c for c in frame.columns if c not in columns]
    return frame[[*columns, *extra]]


def write_csv(frame: pd.DataFrame, path: Path, columns: Sequence[str] | None = None) -> Path:
    """Write ``frame`` as CSV with the project's fixed float format; empty cells for NaN.

    A name ending in ``.gz`` is gzip-compressed (with a zero timestamp: same bytes for the
    same table). The bytes are those of pandas' ``to_csv(index=False,
    float_format=FLOAT_FORMAT, lineterminator="\\n")``, made by the compiled writer of
    :mod:`coopproc.io.csv_fast` (pandas itself for a table that writer does not take).
    """
    frame = columns_first(frame, path, columns)
    from coopproc.io.csv_fast import csv_chunks  # numba: imported late
    from coopproc.io.csv_gzip import write_csv_gzip

    if path.name.endswith(".gz"):
        if not write_csv_gzip(frame, path):
            frame.to_csv(
                path,
                index=False,
                float_format=FLOAT_FORMAT,
                lineterminator="\n",
                compression={"method": "gzip", "mtime": 0},
            )
        return path
    pieces = csv_chunks(frame)
    if pieces is None:
        frame.to_csv(path, index=False, float_format=FLOAT_FORMAT, lineterminator="\n")
        return path
    with open(path, "wb") as out:
        for piece in pieces:
            out.write(piece)
    return path


def csv_text(frame: pd.DataFrame) -> str:
    """The CSV text :func:`write_csv` writes for ``frame`` (all its columns, in order)."""
    from coopproc.io.csv_fast import csv_bytes

    data = csv_bytes(frame)
    if data is None:
        return str(frame.to_csv(index=False, float_format=FLOAT_FORMAT, lineterminator="\n"))
    return data.decode("utf-8")
