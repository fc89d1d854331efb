"""``coopproc batch SESSION... -o ROOT``: many sessions on a Dask cluster."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from coopproc.cli.options import config_option, output_option

__all__ = ["batch"]


@click.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
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
@click.option("--threads", is_flag=True, help="Local cluster with threads instead of processes.")
@click.option("--force", is_flag=True, help="Replace existing per-session output directories.")
@click.option("--no-figures", is_flag=True, help="Tables only.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def batch(
    sessions: tuple[Path, ...],
    out_root: Path,
    config_path: Path | None,
    scheduler: str | None,
    workers: int,
    threads: bool,
    force: bool,
    no_figures: bool,
    quiet: bool,
) -> None:
    """Process many sessions, in parallel on Dask, each exactly as `coopproc run` would.

    A failing session is reported and the others go on; the exit status is 1 if any
    failed. ROOT/batch_metrics.csv and ROOT/batch_position_metrics.csv stack every
    session's Table 2 and Table 3 with a `session` column.
    """
    import dataclasses

    from tqdm import tqdm

    from coopproc.batch import SessionOutcome, run_batch
    from coopproc.config import load_run_config

    config = load_run_config(config_path)
    if no_figures:
        config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
    show_bar = not quiet and sys.stderr.isatty()
    with tqdm(total=len(sessions), disable=not show_bar, unit="session") as bar:

        def done(outcome: SessionOutcome) -> None:
            bar.update(1)
            if not outcome.ok:
                tqdm.write(f"error: {outcome.error}", file=sys.stderr)

        result = run_batch(
            list(sessions),
            out_root,
            config,
            scheduler=scheduler,
            workers=workers,
            processes=not threads,
            force=force,
            on_done=done,
        )
    if not show_bar:
        for outcome in result.failed:
            click.echo(f"error: {outcome.error}", err=True)
    if not quiet:
        ok = len(result.outcomes) - len(result.failed)
        click.echo(f"{ok} of {len(result.outcomes)} sessions processed into {out_root}/", err=True)
        if result.metrics_csv is not None:
            click.echo(f"tables: {result.metrics_csv}, {result.position_metrics_csv}", err=True)
    if result.failed:
        sys.exit(1)
