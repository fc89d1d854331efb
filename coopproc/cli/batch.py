"""``coopproc batch SESSION... -o ROOT``: many sessions on a Dask cluster."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from coopproc.cli.options import config_option, output_option

if TYPE_CHECKING:
    from coopproc.run.batch import BatchInterrupted, BatchResult

__all__ = ["batch"]


@click.command()
# not exists=True: a missing session is one failed session, the others run
@click.argument("sessions", nargs=-1, required=True, type=click.Path(path_type=Path))
@output_option(
    "out_root",
    "Root directory; each session's outputs go to ROOT/<session name>/.",
    required=True,
)
@config_option("Run configuration TOML for every session (see `coopproc config`).")
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    help="Dask scheduler address (tcp://host:8786) of a running cluster; "
    "default: a local cluster on this machine.",
)
@click.option(
    "-j",
    "--workers",
    type=click.IntRange(min=1),
    default=2,
    show_default=True,
    help="Worker processes of the local cluster.",
)
@click.option(
    "--worker-memory",
    metavar="SIZE",
    help="Memory limit of each local worker process (3GB, 1.5GiB, 800MB): a worker "
    "above 95 % of it is restarted and its session fails; default: this machine's "
    "memory divided by the workers.",
)
@click.option("--threads", is_flag=True, help="Local cluster with threads instead of processes.")
@click.option("--force", is_flag=True, help="Replace existing per-session output directories.")
@click.option(
    "--resume",
    is_flag=True,
    help="Skip sessions whose ROOT/<name>/ holds a complete run of their current inputs "
    "with this configuration; redo the others.",
)
@click.option("--no-figures", is_flag=True, help="Tables only.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def batch(
    sessions: tuple[Path, ...],
    out_root: Path,
    config_path: Path | None,
    scheduler: str | None,
    workers: int,
    worker_memory: str | None,
    threads: bool,
    force: bool,
    resume: bool,
    no_figures: bool,
    quiet: bool,
) -> None:
    """Process many sessions, in parallel on Dask, each exactly as `coopproc run` would.

    Each session's outputs go to ROOT/<name>/ (<name>: the session directory's name; two
    sessions of one name are refused). A failing session, a missing path included, is
    reported and the others go on; the exit status is 1 if any failed. ROOT/batch.json
    lists every session under ROOT with its status, earlier calls' included;
    ROOT/batch_metrics.csv and ROOT/batch_position_metrics.csv stack the Table 2 and
    Table 3 of every ok session with a `session` column.
    """
    import dataclasses

    from tqdm import tqdm

    from coopproc.run.batch import BatchInterrupted, SessionOutcome, run_batch
    from coopproc.run.batch_memory import worker_memory_limit
    from coopproc.run.config import load_run_config

    limit = None
    if scheduler is not None and worker_memory is not None:
        click.echo(
            "batch: --worker-memory does not apply to a --scheduler cluster (its workers' "
            "limits are set where they start: dask worker --memory-limit); ignored",
            err=True,
        )
    elif scheduler is None:
        limit, capped = worker_memory_limit(worker_memory, workers)
        if capped is not None:
            click.echo(capped, err=True)
    config = load_run_config(config_path)
    if no_figures:
        config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
    if config.run.format == "parquet":  # [run] format: once here, not once per session
        from coopproc.io.parquet import require_pyarrow

        require_pyarrow()
    show_bar = not quiet and sys.stderr.isatty()
    started = time.perf_counter()
    finished = 0
    with tqdm(total=len(sessions), disable=not show_bar, unit="session") as bar:

        def done(outcome: SessionOutcome) -> None:
            """One line per session as it finishes (its outcome), under the bar."""
            nonlocal finished
            finished += 1
            bar.update(1)
            if not outcome.ok:  # printed here only: once per failed session
                tqdm.write(f"error: {outcome.error}", file=sys.stderr)
            elif not quiet:
                what = "skipped (complete and current)" if outcome.skipped else "done"
                tqdm.write(
                    f"batch: {Path(outcome.out_dir).name} {what} ({finished} of "
                    f"{len(sessions)}, {time.perf_counter() - started:.0f} s)",
                    file=sys.stderr,
                )

        try:
            result = run_batch(
                list(sessions),
                out_root,
                config,
                scheduler=scheduler,
                workers=workers,
                processes=not threads,
                worker_memory=limit,
                force=force,
                resume=resume,
                on_done=done,
            )
        except BatchInterrupted as stop:
            bar.close()
            click.echo(_interrupted_line(stop, len(sessions)), err=True)
            sys.exit(130)
    if not quiet:
        _summary(result, out_root)
    if result.failed:
        sys.exit(1)


def _interrupted_line(stop: BatchInterrupted, n_sessions: int) -> str:
    """The one line of a Ctrl-C: what finished, and that nothing else was left."""
    ok = [Path(o.out_dir).name for o in stop.outcomes if o.ok]
    kept = f" ({', '.join(ok[:5])}{', ...' if len(ok) > 5 else ''})" if ok else ""
    return (
        f"interrupted: {len(ok)} of {n_sessions} sessions processed into {stop.out_root}/{kept}; "
        "the unfinished ones left nothing (--resume goes on from here)"
    )


def _summary(result: BatchResult, out_root: Path) -> None:
    """The closing lines: this call, then ROOT as a whole when it holds more."""
    ran = len(result.outcomes) - len(result.skipped)
    ok = ran - len(result.failed)
    skipped = f"{len(result.skipped)} skipped (complete and current)"
    line = f"{ok} of {ran} sessions processed into {out_root}/"
    if not ran:
        line = f"nothing to process in {out_root}/: {skipped}"
    elif result.skipped:
        line += f"; {skipped}"
    click.echo(line, err=True)
    if len(result.entries) > len(result.outcomes):
        n_ok = sum(e.ok for e in result.entries)
        click.echo(
            f"{out_root}/batch.json: {len(result.entries)} sessions, {n_ok} ok, "
            f"{len(result.entries) - n_ok} failed",
            err=True,
        )
    if result.metrics_csv is not None:
        click.echo(f"tables: {result.metrics_csv}, {result.position_metrics_csv}", err=True)
    _verdicts(out_root)


def _verdicts(out_root: Path) -> None:
    """One line per method pair of ROOT/pooled_comparisons.csv (report/pooled_stats.py)."""
    from coopproc.report.pooled_stats import verdict
    from coopproc.run.batch_root import POOLED_COMPARISONS

    path = out_root / POOLED_COMPARISONS
    if not path.is_file():
        return
    import pandas as pd

    for row in pd.read_csv(path, dtype={"method": str, "baseline": str}).to_dict("records"):
        click.echo(f"pooled: {verdict({str(k): v for k, v in row.items()})}", err=True)
