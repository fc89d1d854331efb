"""``coopproc run SESSION -o OUT``: readers -> stage chain -> tables, figures, report."""

from __future__ import annotations

import datetime as dt
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from coopproc.cli.options import (
    comma_names,
    config_option,
    max_pages_option,
    max_panels_option,
    output_option,
    session_argument,
    style_option,
)

if TYPE_CHECKING:
    from coopproc.model import Session
    from coopproc.report.pages import FigureOptions

__all__ = ["run"]


@click.command()
@session_argument()
@output_option(
    "out_dir",
    "Output directory (replaced only with --force).",
    default=Path("out"),
    show_default=True,
)
@config_option("Run configuration TOML (see `coopproc config`).")
@click.option("--force", is_flag=True, help="Replace an existing output directory.")
@click.option("--pdf", is_flag=True, help="Also write figures as PDF.")
@click.option("--svg", is_flag=True, help="Also write figures as SVG.")
@click.option(
    "--no-figures",
    is_flag=True,
    help="Draw no figures (no figures/); report.html is written without them.",
)
@click.option("--pairs", help="Pairs to draw in the figures, comma separated (e.g. A-B,B-C).")
@click.option("--platforms", help="Platforms to draw in the figures, comma separated.")
@max_panels_option()
@max_pages_option("the config's [run] max_pages, else 2")
@style_option("the config's [run] figure_style, else default")
@click.option(
    "--format",
    "table_format",
    type=click.Choice(["csv", "parquet"]),
    default=None,
    help="Per-epoch tables (ranges, di, nlos_estimates, positions) as CSV or Parquet "
    "(needs pyarrow); default: the config's [run] format, csv.",
)
@click.option(
    "--outage",
    "outages",
    multiple=True,
    metavar="T0:T1",
    help="Withhold the UWB ranges of T0..T1 (seconds from the session start) from every "
    "method and score each method's drift there (outages.csv, outage_drift.png; paper 003 "
    "sec. 3.4); repeatable; replaces the config's [run] outages.",
)
@click.option(
    "--strict",
    is_flag=True,
    help="Refuse a navigation or reference file with a single-row glitch instead of "
    "excluding the row with a note.",
)
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def run(
    session: Path,
    out_dir: Path,
    config_path: Path | None,
    force: bool,
    pdf: bool,
    svg: bool,
    no_figures: bool,
    pairs: str | None,
    platforms: str | None,
    max_panels: int | None,
    max_pages: int | None,
    figure_style: str | None,
    table_format: str | None,
    outages: tuple[str, ...],
    strict: bool,
    quiet: bool,
) -> None:
    """Process a recorded session: clean the ranges, detect and estimate NLOS errors,
    fuse the positions, and write the tables, figures and report to OUT.

    SESSION is a session directory (nav_<ID>.csv, ranges.csv, ref_<ID>.pos, ...) or a
    .mcap file; see docs/formats.md. The closing summary goes to standard output;
    progress and notes go to standard error.
    """
    from coopproc.io.outdir import check_output_dir

    started = dt.datetime.now(dt.UTC)
    started_clock = time.perf_counter()
    windows = _outage_windows(outages)  # a mistyped window fails before the work
    # before the imports and the work: a read-only or mistyped OUT fails at once
    check_output_dir(out_dir, force=force, protect=[session])

    import contextlib
    import dataclasses

    import matplotlib

    matplotlib.use("Agg")
    from coopproc.checks.coverage import nav_gap_spans, prepare_run
    from coopproc.io import read_session
    from coopproc.jit_ahead import AHEAD, compile_ahead
    from coopproc.jit_cache import cold_kernels, compile_note
    from coopproc.memory import Held, release_freed_memory
    from coopproc.run.calibration_summary import calibration_lines
    from coopproc.run.chain import resolve
    from coopproc.run.concurrent_steps import group_steps, workers
    from coopproc.run.config import load_run_config
    from coopproc.run.output import hash_inputs, write_run
    from coopproc.run.pipeline import run_pipeline
    from coopproc.run.progress import PhaseProgress
    from coopproc.run.summary import summarize

    # the closing summary on stdout (`> log` keeps it); progress and notes on stderr
    note = (lambda text: None) if quiet else (lambda text: click.echo(text, err=True))
    say = (lambda text: None) if quiet else click.echo
    config = load_run_config(config_path)
    if no_figures:
        config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
    if table_format is not None:
        config = dataclasses.replace(
            config,
            run=dataclasses.replace(
                config.run, format="parquet" if table_format == "parquet" else "csv"
            ),
        )
    if windows:
        config = dataclasses.replace(config, run=dataclasses.replace(config.run, outages=windows))
    if max_pages is not None:  # run.json records it: `coopproc report --plots` follows it
        config = dataclasses.replace(
            config, run=dataclasses.replace(config.run, max_pages=max_pages)
        )
    if config.run.format == "parquet":
        from coopproc.io.parquet import require_pyarrow

        require_pyarrow()  # before the work
    show_bar = not quiet and sys.stderr.isatty()
    # read, prepare, the chain's steps, metrics, summary, tables, (figures,) html
    steps = resolve(config.pipeline)
    total = len(steps) + 6 + (1 if config.run.figures else 0)
    with (
        PhaseProgress(
            total,
            bar=show_bar,
            log=None if quiet else note,
            prefix="run",
            on_phase=release_freed_memory,  # the runner's memory at each boundary (memory.py)
        ) as phases,
        contextlib.ExitStack() as compiling_ahead,
    ):
        phases.start("read")
        data = read_session(session, strict=strict)
        figure_options = _figure_options(
            data, pairs, platforms, max_panels, figure_style or config.run.figure_style
        )  # checked early
        figure_options = dataclasses.replace(figure_options, max_pages=config.run.max_pages)
        check_output_dir(out_dir, force=force, protect=[data.root, *data.inputs])
        input_sha256 = hash_inputs(data.inputs)  # run.json's digests, in a thread meanwhile
        note(
            f"session {data.name}: {len(data.platforms)} platforms, "
            f"{len(data.ranges.pairs)} pairs, {len(data.ranges)} ranges"
        )
        # ranges the navigation does not cover left out, frames checked; notes appended
        phases.start("prepare")
        data, _ = prepare_run(data)
        nav_gaps = nav_gap_spans(data)  # run.json's, before the samples are let go of
        # steps run two at a time are one phase (run.concurrent_steps)
        together = workers(config.run.parallel_fusion, len(data.ranges))
        phases.set_total(total - len(steps) + len(group_steps(steps, together)))
        for text in data.notes:  # implausible jumps are "warning: ..." (io/plausible.py)
            note(text if text.startswith("warning: ") else f"note: {text}")
        # a cold cache: the later kernels compiled in a second process meanwhile
        # (jit_ahead), and the first run's half minute said
        cold = cold_kernels()
        if compiling_ahead.enter_context(compile_ahead(cold)):
            ahead = {(m, k) for m, k, _ in AHEAD}
        else:
            ahead = set()
        compiling = None if quiet else compile_note(cold=cold, ahead=ahead)
        if compiling is not None:
            note(compiling)

        # handed over: the pipeline lets go of the samples once its metrics have read them
        held = Held(data)
        del data
        output = run_pipeline(held, config, progress=phases.start)
        data = held.value
        del held
        phases.start("summary")
        summary = summarize(output)
        phases.end()
        before = {k: phases.timings_s[k] for k in ("read", "prepare")}
        # the samples are spent (let go of by the pipeline already, unless it ran with
        # outages): the writing (and the figures' forked workers) holds none
        data = data.without_samples()
        formats = ("png",) + (("pdf",) if pdf else ()) + (("svg",) if svg else ())
        files = write_run(
            output,
            data,
            config,
            out_dir,
            force=force,
            figure_formats=formats,
            started=started,
            started_clock=started_clock,
            summary=summary.facts,
            figure_options=figure_options,
            progress=phases.start,
            timings_before=before,
            timings_after={"summary": phases.timings_s["summary"]},
            input_sha256=input_sha256,
            nav_gaps=nav_gaps,
        )
    for text in files.notes:  # e.g. what the figures' page cap left out
        note(f"note: {text.replace('coopproc report OUT', f'coopproc report {out_dir}')}")
    for line in calibration_lines(output):
        say(line)
    for line in summary.lines:
        say(line)
    parquet = sum(p.suffix == ".parquet" for p in files.tables)
    kinds = f"{len(files.tables) - parquet} CSV" + (f", {parquet} Parquet" if parquet else "")
    say(f"tables: {files.out_dir}/ ({kinds}), figures: {len(files.figures)}")
    if files.html is not None:
        say(f"report: {files.html}")


def _outage_windows(given: tuple[str, ...]) -> tuple[tuple[float, float], ...]:
    """``--outage T0:T1`` values as (t0, t1) pairs; a malformed one is a usage error."""
    from coopproc.run.outages import parse_outage

    out = []
    for text in given:
        try:
            out.append(parse_outage(text))
        except ValueError as err:
            raise click.BadParameter(str(err), param_hint="'--outage'") from err
    return tuple(out)


def _figure_options(
    data: Session,
    pairs: str | None,
    platforms: str | None,
    max_panels: int | None,
    style: str = "default",
) -> FigureOptions:
    """--pairs / --platforms / --max-panels checked against the session's pairs and
    platforms (an unknown one is a one-line error listing them); --style."""
    from coopproc.report.pages import FigureOptions, check_names
    from coopproc.report.style import MAX_PANELS, figure_style

    chosen_pairs = comma_names(pairs)
    chosen_platforms = comma_names(platforms)
    return FigureOptions(
        pairs=None
        if chosen_pairs is None
        else check_names(chosen_pairs, sorted(data.ranges.pairs), "pair"),
        platforms=None
        if chosen_platforms is None
        else check_names(chosen_platforms, sorted(data.platforms), "platform"),
        max_panels=max_panels or MAX_PANELS,
        style=figure_style(style),
    )
