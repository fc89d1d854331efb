"""Many sessions at once on Dask: ``coopproc batch SESSION... -o ROOT``.

Each session is one task (read -> pipeline -> write ``ROOT/<session>/``, exactly what
``coopproc run`` writes), run on a Dask cluster: a local one by default, or the scheduler
at ``scheduler`` for a real cluster. A session that fails is reported with its one-line
error and does not stop the others. The per-session tables are collected into
``ROOT/batch_metrics.csv`` and ``ROOT/batch_position_metrics.csv`` (a ``session`` column
first), and ``ROOT/batch.json`` lists every session with its status.
"""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from coopproc.config import RunConfig
from coopproc.errors import CoopprocError, OutputError
from coopproc.outdir import write_csv

__all__ = ["BatchResult", "SessionOutcome", "run_batch", "run_one"]


@dataclass(frozen=True)
class SessionOutcome:
    """What became of one session of a batch."""

    session: str
    out_dir: str
    ok: bool
    error: str = ""
    metrics: pd.DataFrame | None = None
    position_metrics: pd.DataFrame | None = None


@dataclass(frozen=True)
class BatchResult:
    outcomes: tuple[SessionOutcome, ...]
    metrics_csv: Path | None
    position_metrics_csv: Path | None

    @property
    def failed(self) -> tuple[SessionOutcome, ...]:
        return tuple(o for o in self.outcomes if not o.ok)


def run_one(
    session_path: str, out_dir: str, config: RunConfig, force: bool, formats: tuple[str, ...]
) -> SessionOutcome:
    """Process one session into ``out_dir`` (the task each Dask worker runs)."""
    import matplotlib

    matplotlib.use("Agg")
    from coopproc.coverage import prepare_run
    from coopproc.io import read_session
    from coopproc.output import write_run
    from coopproc.pipeline import run_pipeline
    from coopproc.summary import summarize

    started = dt.datetime.now(dt.UTC)
    try:
        session, _ = prepare_run(read_session(session_path))
        output = run_pipeline(session, config)
        write_run(
            output,
            session,
            config,
            out_dir,
            force=force,
            figure_formats=formats,
            started=started,
            summary=summarize(output).facts,
        )
    except CoopprocError as err:
        return SessionOutcome(session_path, out_dir, ok=False, error=str(err))
    return SessionOutcome(
        session_path,
        out_dir,
        ok=True,
        metrics=output.result.metrics,
        position_metrics=output.result.position_metrics,
    )


def _out_names(sessions: Sequence[Path]) -> list[str]:
    """One output directory name per session: its name, made unique with -2, -3, ..."""
    names: list[str] = []
    for s in sessions:
        base = s.stem if s.is_file() else s.resolve().name
        name, i = base, 2
        while name in names:
            name, i = f"{base}-{i}", i + 1
        names.append(name)
    return names


def run_batch(
    sessions: Sequence[Path],
    out_root: Path,
    config: RunConfig,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    force: bool = False,
    formats: tuple[str, ...] = ("png",),
    on_done: Callable[[SessionOutcome], None] | None = None,
) -> BatchResult:
    """Run every session on Dask; see the module docstring."""
    from dask.distributed import Client, LocalCluster, as_completed

    if not sessions:
        raise CoopprocError("batch: no sessions given")
    out_root = Path(out_root)
    if out_root.exists() and not out_root.is_dir():
        raise OutputError(f"{out_root}: exists and is not a directory")
    out_root.mkdir(parents=True, exist_ok=True)
    names = _out_names(sessions)
    jobs = [(str(s), str(out_root / n)) for s, n in zip(sessions, names, strict=True)]

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,
        )
    try:
        with Client(scheduler if scheduler is not None else cluster) as client:
            futures = {
                client.submit(run_one, s, o, config, force, formats, pure=False): s for s, o in jobs
            }
            by_session: dict[str, SessionOutcome] = {}
            for future in as_completed(futures):
                try:
                    outcome = future.result()
                except Exception as err:  # a worker died or the task raised
                    session = futures[future]
                    outcome = SessionOutcome(
                        session, "", ok=False, error=f"{type(err).__name__}: {err}"
                    )
                by_session[outcome.session] = outcome
                if on_done is not None:
                    on_done(outcome)
    finally:
        if cluster is not None:
            cluster.close()
    outcomes = tuple(by_session[s] for s, _ in jobs)  # input order: deterministic files
    return _write_summary(out_root, outcomes, names)


def _stack(outcomes: Sequence[SessionOutcome], names: Sequence[str], attr: str) -> pd.DataFrame:
    frames = []
    for outcome, name in zip(outcomes, names, strict=True):
        table = getattr(outcome, attr)
        if outcome.ok and table is not None:
            frames.append(table.assign(session=name)[["session", *table.columns]])
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _write_summary(
    out_root: Path, outcomes: tuple[SessionOutcome, ...], names: Sequence[str]
) -> BatchResult:
    metrics = _stack(outcomes, names, "metrics")
    positions = _stack(outcomes, names, "position_metrics")
    metrics_csv = positions_csv = None
    if len(metrics):
        metrics_csv = write_csv(metrics, out_root / "batch_metrics.csv")
    if len(positions):
        positions_csv = write_csv(positions, out_root / "batch_position_metrics.csv")
    listing: list[dict[str, Any]] = [
        {"session": o.session, "output": n, "ok": o.ok, "error": o.error}
        for o, n in zip(outcomes, names, strict=True)
    ]
    (out_root / "batch.json").write_text(json.dumps({"sessions": listing}, indent=2) + "\n")
    return BatchResult(outcomes, metrics_csv, positions_csv)
