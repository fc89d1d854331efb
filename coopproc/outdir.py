"""Atomic output directories and deterministic CSV writing.

Outputs are written into a temporary sibling directory and renamed into place only when
complete, so a crash never leaves a half-written output. An existing output directory is
not replaced unless ``force`` is given; it is never a directory holding session inputs.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

import pandas as pd

from coopproc.errors import OutputError

__all__ = ["atomic_output_dir", "check_output_dir", "write_csv"]

#: Float format of every output CSV: enough digits for millimetres on any time base, and
#: the same bytes for the same numbers (determinism).
FLOAT_FORMAT = "%.6f"


def check_output_dir(
    path: str | Path, *, force: bool = False, protect: Sequence[Path] = ()
) -> Path:
    """Raise OutputError now if ``path`` cannot be the output (see atomic_output_dir).

    Called before long work so that a user learns of an existing directory at once.
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
    return target


@contextlib.contextmanager
def atomic_output_dir(
    path: str | Path, *, force: bool = False, protect: Sequence[Path] = ()
) -> Iterator[Path]:
    """Yield a temporary directory that becomes ``path`` when the block ends without error.

    ``protect``: input paths that must never be overwritten or deleted (a run into the
    session directory itself is refused).
    """
    target = check_output_dir(path, force=force, protect=protect)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    os.chmod(tmp, 0o755)
    if target.exists():
        old = target.with_name(f".{target.name}.old-{os.getpid()}")
        target.rename(old)
        tmp.rename(target)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(target)


def write_csv(frame: pd.DataFrame, path: Path, columns: Sequence[str] | None = None) -> Path:
    """Write ``frame`` as CSV with the project's fixed float format; empty cells for NaN.

    A name ending in ``.gz`` is gzip-compressed (with a zero timestamp: same bytes for the
    same table).
    """
    if columns is not None:
        missing = [c for c in columns if c not in frame.columns]
        if missing:
            raise OutputError(f"{path.name}: missing columns {missing}")
        extra = [c for c in frame.columns if c not in columns]
        frame = frame[[*columns, *extra]]
    frame.to_csv(
        path,
        index=False,
        float_format=FLOAT_FORMAT,
        lineterminator="\n",
        compression={"method": "gzip", "mtime": 0} if path.name.endswith(".gz") else None,
    )
    return path
