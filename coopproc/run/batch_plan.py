"""What ``coopproc batch`` checks and decides per session before any work.

The output names (``<name>``: the session directory's name, an ``.mcap`` file's name
without the suffix; two sessions of one name are refused), ROOT (a directory that can be
written), and each ``ROOT/<name>/``: an existing one is replaced only with ``force``; with
``resume`` a complete and current run there is kept and its session skipped, a stale one
redone (coopproc.run.batch_root). A missing session path is a failed outcome, known
without running. Used by :func:`coopproc.run.batch.run_batch`.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from coopproc.errors import OutputError
from coopproc.io.outdir import check_output_dir
from coopproc.run.batch_root import BatchEntry, run_json, stale_reason
from coopproc.run.config import RunConfig

__all__ = [
    "SessionOutcome",
    "failed_outcome",
    "make_root",
    "os_cause",
    "out_names",
    "plan_sessions",
]


@dataclass(frozen=True)
class SessionOutcome:
    """What became of one session of this call (``skipped``: kept by ``resume``)."""

    session: str
    out_dir: str
    ok: bool
    error: str = ""
    skipped: bool = False


def failed_outcome(session: str, out_dir: str, error: str) -> SessionOutcome:
    """A failure whose one-line error names the session."""
    error = " ".join(error.splitlines())
    if session not in error:
        error = f"{session}: {error}"
    return SessionOutcome(session, out_dir, ok=False, error=error)


def os_cause(err: OSError) -> str:
    """The cause of an OS error in a few words (its strerror)."""
    return err.strerror or (os.strerror(err.errno) if err.errno else str(err)) or type(err).__name__


def out_names(sessions: Sequence[Path], out_root: Path) -> list[str]:
    """One output directory name per session; two sessions of one name are an error."""
    names: dict[str, Path] = {}
    for s in sessions:
        name = s.stem if s.is_file() else s.resolve().name
        if name in names:
            raise OutputError(
                f"sessions {names[name]} and {s} would both write {out_root / name}/ "
                "(outputs are named after the session directory or .mcap file); "
                "rename one, or batch them into different ROOTs"
            )
        names[name] = s
    return list(names)


def make_root(out_root: Path) -> None:
    """Create ROOT and check that it can be written, before any work."""
    if out_root.exists() and not out_root.is_dir():
        raise OutputError(f"{out_root}: exists and is not a directory")
    try:
        out_root.mkdir(parents=True, exist_ok=True)
        os.rmdir(tempfile.mkdtemp(prefix=".coopproc-probe.", dir=out_root))
    except OSError as err:
        base = next((p for p in out_root.absolute().parents if p.exists()), None)
        if base is not None and not base.is_dir():
            raise OutputError(f"{out_root}: cannot create the directory: {base} is a file") from err
        raise OutputError(f"{out_root}: cannot write the outputs there ({os_cause(err)})") from err


def plan_sessions(
    sessions: Sequence[Path],
    names: Sequence[str],
    out_root: Path,
    config: RunConfig,
    earlier: dict[str, BatchEntry],
    *,
    force: bool,
    resume: bool,
) -> dict[str, tuple[SessionOutcome | None, bool]]:
    """Per output name: the outcome known without running (missing path, skipped by
    ``resume``) or None, and whether the run replaces ``ROOT/<name>/``.

    Raises before any work for outputs that exist without ``force`` or ``resume`` (one
    line for them all) and, with ``resume``, for a directory that is not a coopproc run
    or holds the run of another session that still exists.
    """
    plans: dict[str, tuple[SessionOutcome | None, bool]] = {}
    exist: list[str] = []
    for session, name in zip(sessions, names, strict=True):
        out_dir = out_root / name
        if not session.exists():
            error = f"{session}: no such file or directory; expected a session directory or .mcap"
            plans[name] = (failed_outcome(str(session), str(out_dir), error), False)
            continue
        check_output_dir(out_dir, force=True, protect=[session])
        if not out_dir.is_dir() or not any(out_dir.iterdir()):
            plans[name] = (None, False)
        elif resume and run_json(out_dir) is not None:
            if not force:
                _check_same_session(session, out_dir, earlier.get(name))
            if stale_reason(out_dir, session, config) is None:
                plans[name] = (
                    SessionOutcome(str(session), str(out_dir), ok=True, skipped=True),
                    False,
                )
            else:
                plans[name] = (None, True)
        elif force:
            plans[name] = (None, True)
        elif resume:
            raise OutputError(
                f"{out_dir}: exists and holds no coopproc run (no run.json); "
                "use --force to replace it"
            )
        else:
            exist.append(name)
    if exist:
        shown = ", ".join(exist[:5]) + (", ..." if len(exist) > 5 else "")
        raise OutputError(
            f"{out_root}: {len(exist)} of these sessions have outputs there already ({shown}); "
            "use --resume to skip the complete ones and redo the rest, or --force to replace them"
        )
    return plans


def _check_same_session(session: Path, out_dir: Path, earlier: BatchEntry | None) -> None:
    """Refuse to redo into ``out_dir`` the run of another session of the same name."""
    recorded = Path(earlier.session) if earlier is not None and earlier.session else None
    if recorded is None:
        info = run_json(out_dir) or {}
        path = (info.get("session") or {}).get("path")
        recorded = Path(path) if isinstance(path, str) else None
    if recorded is None or not recorded.is_absolute():
        return  # unknown: the inputs' check decides
    if recorded.resolve() != session.resolve() and recorded.exists():
        raise OutputError(
            f"{out_dir}: holds the run of {recorded}, not of {session} (outputs are named "
            "after the session directory); batch it into another ROOT, or use --force to "
            "replace it"
        )
