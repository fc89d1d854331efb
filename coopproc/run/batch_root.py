"""The ROOT of ``coopproc batch``: which runs in it are complete and current, and the
files that describe them all (``batch.json``, ``batch_metrics.csv``,
``batch_position_metrics.csv``, ``pooled_position_metrics.csv``,
``pooled_comparisons.csv``).

A run directory ``ROOT/<name>/`` is *complete* when it holds ``run.json`` and every table
``coopproc run`` writes (and every figure run.json lists); it is *current* for a session
when, moreover, it was written by this coopproc version with this configuration from the
inputs the session has now: the same files, each with the SHA-256 run.json records.

The listing is rebuilt on every call from ROOT itself, so it always describes every
session there: this call's sessions, each other ``ROOT/<name>/`` holding a complete run,
and the failures of earlier calls not retried since, unless a run of that name started
after the failure (a failed rerun leaves the older run in place; the failure outdates
it). Hidden directories (``.name``: temporary ones) are not sessions.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import hashlib
import json
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from coopproc.errors import CoopprocError, OutputError
from coopproc.io.outdir import write_csv
from coopproc.model import POSITIONS_COLUMNS
from coopproc.report.pooled import pooled_tables
from coopproc.report.rundir import RUN_FILES, find_table, read_table_file
from coopproc.run.config import RunConfig

__all__ = [
    "POOLED",
    "POOLED_COMPARISONS",
    "STACKED",
    "BatchEntry",
    "complete_run",
    "merge_listing",
    "read_listing",
    "run_json",
    "stale_reason",
    "write_listing",
]

#: The stacked tables: (file under ROOT, the table of each run it stacks).
STACKED = (
    ("batch_metrics.csv", "metrics.csv"),
    ("batch_position_metrics.csv", "position_metrics.csv"),
)
#: The position statistics pooled over the ok sessions' errors (report/pooled.py).
POOLED = "pooled_position_metrics.csv"
#: The methods compared over the ok sessions (report/pooled_stats.py).
POOLED_COMPARISONS = "pooled_comparisons.csv"


@dataclass(frozen=True)
class BatchEntry:
    """One session of ``ROOT/batch.json``.

    ``session``: its absolute path; ``output``: its directory name under ROOT; ``ok`` and
    the one-line ``error``; ``status``: ``processed``, ``skipped`` (kept by --resume) or
    ``failed`` in this call, ``earlier`` for a result of an earlier call; ``time``: the
    run's start (run.json ``start_time``) or, for a failure, the start of the call that
    failed, UTC ISO 8601.
    """

    session: str
    output: str
    ok: bool
    error: str
    status: str
    time: str


def run_json(out_dir: Path) -> dict[str, Any] | None:
    """The object in ``out_dir/run.json``; None when there is none or it is not JSON."""
    try:
        info = json.loads((out_dir / "run.json").read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return info if isinstance(info, dict) else None


def _incomplete(out_dir: Path) -> tuple[dict[str, Any] | None, str | None]:
    """run.json and what is missing from a complete run (None: nothing)."""
    info = run_json(out_dir)
    if info is None:
        return None, "no readable run.json"
    figures = info.get("figures")
    listed = [f for f in figures if isinstance(f, str)] if isinstance(figures, list) else []
    for name, *_ in RUN_FILES:
        if find_table(out_dir, name) is None:
            return info, f"{name} missing"
    for name in listed:
        if not (out_dir / name).is_file():
            return info, f"{name} missing"
    return info, None


def complete_run(out_dir: Path) -> dict[str, Any] | None:
    """run.json of ``out_dir`` when it holds a complete run, else None."""
    info, missing = _incomplete(out_dir)
    return info if missing is None else None


def stale_reason(out_dir: Path, session: Path, config: RunConfig) -> str | None:
    """Why ``out_dir`` does not hold a complete, current run of ``session`` (None: it does).

    Never raises: a session or run.json that cannot be read is a reason to redo the run.
    """
    from coopproc import __version__

    info, missing = _incomplete(out_dir)
    if info is None or missing is not None:
        return f"incomplete run ({missing})"
    if info.get("coopproc_version") != __version__:
        return f"written by coopproc {info.get('coopproc_version')}"
    if info.get("config") != json.loads(json.dumps(config.to_dict())):
        return "another configuration"
    base = session if session.is_dir() else session.parent
    try:
        recorded = {(base / i["file"]).resolve(): i["sha256"] for i in info["inputs"]}
        found = {p.resolve() for p in _session_inputs(session)}
        new, gone = sorted(found - recorded.keys()), sorted(recorded.keys() - found)
        if new or gone:
            return f"new input {new[0].name}" if new else f"input {gone[0].name} gone"
        for path, digest in recorded.items():
            with path.open("rb") as handle:
                if hashlib.file_digest(handle, "sha256").hexdigest() != digest:
                    return f"input {path.name} changed"
        reason = _injected_reason(info.get("injected"), session)
        if reason is not None:
            return reason
    except (KeyError, TypeError) as err:
        return f"run.json inputs unreadable ({err})"
    except (CoopprocError, OSError) as err:
        return f"session unreadable ({err})"
    return None


def _injected_reason(recorded: Any, session: Path) -> str | None:
    """The scores of a `coopproc inject` session follow its injected.csv (run.json
    ``injected``): one added, removed or changed since the run makes it not current."""
    path = session / "injected.csv"
    if not session.is_dir() or (recorded is None and not path.is_file()):
        return None
    if recorded is None:
        return "new input injected.csv"
    if not path.is_file():
        return "input injected.csv gone"
    with path.open("rb") as handle:
        if hashlib.file_digest(handle, "sha256").hexdigest() != recorded["sha256"]:
            return "input injected.csv changed"
    return None


def _session_inputs(session: Path) -> list[Path]:
    """The files ``read_session`` reads from ``session`` (those run.json lists)."""
    if not session.is_dir():
        return [session]
    from coopproc.io.registry import find_files
    from coopproc.io.session_toml import read_session_toml
    from coopproc.model import SessionConfig

    toml = session / "session.toml"
    config = read_session_toml(toml).config if toml.is_file() else SessionConfig()
    files = find_files(session, config)
    optional = (toml if toml.is_file() else None, files.ranges, files.mcap)
    return [*files.nav.values(), *files.ref.values(), *(p for p in optional if p is not None)]


def read_listing(path: Path) -> dict[str, BatchEntry]:
    """The entries of an earlier ``batch.json`` by output name (status ``earlier``).

    A missing or unreadable file is no entries: the listing is rebuilt from ROOT.
    """
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return {}
    items = doc.get("sessions") if isinstance(doc, dict) else None
    out: dict[str, BatchEntry] = {}
    for item in items if isinstance(items, list) else []:
        if isinstance(item, dict) and isinstance(item.get("output"), str):
            out[item["output"]] = BatchEntry(
                session=str(item.get("session", "")),
                output=item["output"],
                ok=item.get("ok") is True,
                error=str(item.get("error", "")),
                status="earlier",
                time=str(item.get("time", "")),
            )
    return out


def merge_listing(
    out_root: Path, this_call: Mapping[str, BatchEntry], earlier: Mapping[str, BatchEntry]
) -> list[BatchEntry]:
    """Every session under ROOT, sorted by output name (see the module docstring)."""
    on_disk = {p.name for p in out_root.iterdir() if p.is_dir() and not p.name.startswith(".")}
    entries = []
    for name in sorted(set(this_call) | set(earlier) | on_disk):
        if name in this_call:
            entries.append(this_call[name])
            continue
        old = earlier.get(name)
        info = complete_run(out_root / name)
        run = None
        if info is not None:
            path = (info.get("session") or {}).get("path", "")
            session = old.session if old is not None else str(path)
            run = BatchEntry(session, name, True, "", "earlier", str(info.get("start_time", "")))
        if old is not None and not old.ok and (run is None or not _later(run.time, old.time)):
            entries.append(old)
        elif run is not None:
            entries.append(run)
    return entries


def _later(a: str, b: str) -> bool:
    """Whether ISO time ``a`` is after ``b`` (an unreadable time is the earliest)."""

    def parse(text: str) -> dt.datetime:
        try:
            when = dt.datetime.fromisoformat(text)
        except ValueError:
            return dt.datetime.min.replace(tzinfo=dt.UTC)
        return when if when.tzinfo else when.replace(tzinfo=dt.UTC)

    return parse(a) > parse(b)


def write_listing(out_root: Path, entries: Sequence[BatchEntry]) -> tuple[Path | None, ...]:
    """Write ``batch.json`` and the stacked tables; the tables' paths (None: no ok run).

    A stacked table holds each ok session's table as written (the same text, cell for
    cell) after a ``session`` column; a stale one is removed when no session is ok.
    """
    doc = {"sessions": [dataclasses.asdict(e) for e in entries]}
    _write_atomic(out_root / "batch.json", lambda p: p.write_text(json.dumps(doc, indent=2) + "\n"))
    paths: list[Path | None] = []
    for name, table in STACKED:
        frames = []
        for e in entries:
            if e.ok:
                frame = _read_text_table(out_root / e.output / table)
                frames.append(frame.assign(session=e.output)[["session", *frame.columns]])
        path = out_root / name
        if frames:
            stacked = pd.concat(frames, ignore_index=True)
            _write_atomic(path, _csv_writer(stacked))
            paths.append(path)
        else:
            path.unlink(missing_ok=True)
            paths.append(None)
    _write_pooled(out_root, [e.output for e in entries if e.ok])
    return tuple(paths)


def _write_pooled(out_root: Path, names: Sequence[str]) -> None:
    """``POOLED`` and ``POOLED_COMPARISONS`` from the ok runs' ``positions.csv`` (removed
    when there is none)."""
    path = out_root / POOLED
    if not names:
        path.unlink(missing_ok=True)
        (out_root / POOLED_COMPARISONS).unlink(missing_ok=True)
        return

    def positions() -> Iterator[tuple[str, pd.DataFrame]]:
        """Each run's positions table, read when its turn comes (50 one-hour runs of 10
        platforms held at once took 10 GB; one at a time, only their errors are kept)."""
        for name in names:  # positions.csv, or positions.parquet of a --format parquet run
            run_dir = out_root / name
            table = find_table(run_dir, "positions.csv") or run_dir / "positions.csv"
            try:
                frame = read_table_file(table, text=("platform", "method"))
            except (OSError, ValueError, ImportError, pd.errors.ParserError) as err:
                raise OutputError(f"{table}: cannot read it to pool ({err})") from err
            missing = [c for c in POSITIONS_COLUMNS if c not in frame.columns]
            if missing:
                raise OutputError(f"{table}: cannot pool it: missing columns {missing}")
            yield name, frame

    pooled, compared = pooled_tables(positions())
    _write_atomic(path, _csv_writer(pooled))
    _write_atomic(out_root / POOLED_COMPARISONS, _csv_writer(compared))


def _csv_writer(frame: pd.DataFrame) -> Callable[[Path], Any]:
    return lambda path: write_csv(frame, path)


def _read_text_table(path: Path) -> pd.DataFrame:
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise OutputError(f"{path}: cannot read it to stack ({err})") from err


def _write_atomic(path: Path, write: Callable[[Path], Any]) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``: never a half-written file."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        cause = err.strerror or type(err).__name__
        raise OutputError(f"{path}: cannot write ({cause})") from err
