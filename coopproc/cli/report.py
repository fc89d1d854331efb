"""``coopproc report OUT``: the paper's tables, figures and HTML page from a finished run."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from coopproc.cli.options import (
    comma_names,
    max_pages_option,
    max_panels_option,
    style_option,
)

if TYPE_CHECKING:
    from coopproc.report.run_tables import RunTables

__all__ = ["report"]


def _lengths(value: str) -> list[float]:
    """``--rpe``: positive segment lengths in metres (``none``: no RPE table)."""
    if value.strip().lower() == "none":
        return []
    out = []
    for item in value.split(","):
        try:
            length = float(item)
        except ValueError:
            length = float("nan")
        if not (length > 0 and length != float("inf")):
            raise click.BadParameter(
                f"{item.strip()!r} is not a segment length; expected positive metres, e.g. "
                "10,50,100",
                param_hint="'--rpe'",
            )
        out.append(length)
    return out


def _alignments(value: str | None) -> list[str]:
    """``--align``: known alignment names (default ``none``)."""
    import difflib

    from coopproc.report.alignment import ALIGNMENTS

    names = comma_names(value) or ["none"]
    for name in names:
        if name not in ALIGNMENTS:
            near = difflib.get_close_matches(name, ALIGNMENTS, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise click.BadParameter(
                f"unknown alignment {name!r}{hint}; expected {', '.join(ALIGNMENTS)}",
                param_hint="'--align'",
            )
    return names


def _level(value: str | None, default: float, option: str) -> float | None:
    """``--ci`` / ``--significance``: a number in (0, 1), or ``none``."""
    if value is None:
        return default
    if value.strip().lower() == "none":
        return None
    try:
        level = float(value)
    except ValueError:
        level = float("nan")
    if not 0.0 < level < 1.0:
        raise click.BadParameter(
            f"{value!r} is not a level; expected a number between 0 and 1 (e.g. 0.9) or none",
            param_hint=f"'{option}'",
        )
    return level


def _outage_origin(run: RunTables) -> float:
    """The session start the run's outage windows count from (run.json ``outages``), else
    the run's time origin."""
    windows = (run.info.get("outages") or {}).get("windows") or []
    if windows and all(k in windows[0] for k in ("start", "start_s")):
        return float(windows[0]["start"]) - float(windows[0]["start_s"])
    return run.time_origin_s


def _run_max_pages(run: RunTables) -> int:
    """The run's ``[run] max_pages`` (run.json), else the default."""
    from coopproc.report.style import MAX_PAGES

    value = ((run.info.get("config") or {}).get("run") or {}).get("max_pages")
    return value if isinstance(value, int) and value >= 0 else MAX_PAGES


@click.command("report")
@click.argument("out", type=click.Path(path_type=Path, file_okay=False))
@click.option("--table", "show_table", is_flag=True, help="Print Table 2 and Table 3 (default).")
@click.option(
    "--axes",
    is_flag=True,
    help="Also print Table 3 per axis: E/N/U RMS and max of the position error, velocity "
    "and attitude RMS where states.csv has a reference (implies --table).",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["terminal", "csv", "md", "latex"]),
    default=None,
    help="Table format (implies --table). Default: terminal.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, dir_okay=False),
    help="Write the tables to FILE instead of standard output.",
)
@click.option(
    "--latex-width",
    type=click.Choice(["single", "double"]),
    default="single",
    show_default=True,
    help="Page the LaTeX tables fit: single (one-column article) or double (one column of a "
    "two-column article, else table* across both).",
)
@click.option(
    "--no-change",
    "no_change",
    is_flag=True,
    help="Leave out the change against Observed (every format).",
)
@click.option(
    "--ci",
    "ci",
    metavar="LEVEL",
    help="Confidence level of the intervals of Table 2 and Table 3 (block bootstrap over "
    "time; default 0.95; none: no intervals).",
)
@click.option(
    "--significance",
    metavar="ALPHA",
    help="Mark the changes against Observed whose paired comparison has p < ALPHA "
    "(default 0.05; none: no marks).",
)
@click.option("--metrics", help="Columns to show, comma separated (e.g. max,rmse,snr_db).")
@click.option(
    "--pairs", help="Pairs to show in Table 2 and the figures, comma separated (e.g. A-B,B-C)."
)
@click.option("--platforms", help="Platforms to show in Table 3 and the figures, comma separated.")
@click.option("--plots", is_flag=True, help="Remake the figures in OUT/figures (PNG).")
@click.option("--pdf", is_flag=True, help="Also write PDF figures (implies --plots).")
@click.option("--svg", is_flag=True, help="Also write SVG figures (implies --plots).")
@click.option(
    "--dpi",
    type=click.IntRange(50, 1200),
    default=300,
    show_default=True,
    help="Resolution of PNG figures.",
)
@max_panels_option()
@max_pages_option("the run's [run] max_pages, else 2")
@style_option()
@click.option("--html", "make_html", is_flag=True, help="Write OUT/report.html.")
@click.option(
    "--evaluate",
    is_flag=True,
    help="Print the trajectory evaluation instead of Table 2/3: 3-D, horizontal and "
    "vertical errors and the relative error per travelled distance (from positions.csv).",
)
@click.option(
    "--align",
    help="Alignment(s) before the evaluation statistics, comma separated: none (default), "
    "se2, yaw, se3, sim3 (docs/report.md; implies --evaluate).",
)
@click.option(
    "--rpe",
    "rpe_lengths",
    help="RPE segment lengths in metres, comma separated (default 10,50,100; none: no RPE "
    "table; implies --evaluate).",
)
@click.option(
    "--outages",
    "show_outages",
    is_flag=True,
    help="Print the drift inside the run's UWB outage windows instead of Table 2/3: each "
    "method's horizontal error at the start and end of each window, its max and RMS "
    "(OUT/outages.csv, written by `coopproc run --outage T0:T1`; paper 003 sec. 3.4).",
)
@click.option(
    "--stochastic",
    is_flag=True,
    help="Print the stochastic analysis instead of Table 2/3: UWB range residuals on "
    "line-of-sight epochs per pair (bias, sigma, ACF, normality; paper 002 sec. 5.1) and the "
    "Allan deviation of the session's imu_<ID>.csv; writes OUT/stochastic.csv, OUT/allan.csv "
    "(figures with --plots, a report.html section with --html).",
)
@click.option(
    "--imu",
    "imu_files",
    multiple=True,
    type=click.Path(path_type=Path, dir_okay=False),
    help="IMU file (imu_<ID>.csv) for the Allan deviation instead of the session's; "
    "repeatable; implies --stochastic.",
)
@click.option(
    "--allan-tau",
    "allan_tau",
    type=click.FloatRange(min=0.0, min_open=True),
    default=1.0,
    show_default=True,
    metavar="S",
    help="Longest averaging time the Allan deviation must reach, s; the IMU must be at rest "
    "for 10 x this in one stretch (only that stretch is analysed), else the analysis is "
    "refused; implies --stochastic when given.",
)
def report(
    out: Path,
    show_table: bool,
    axes: bool,
    fmt: str | None,
    output: Path | None,
    latex_width: str,
    no_change: bool,
    ci: str | None,
    significance: str | None,
    metrics: str | None,
    pairs: str | None,
    platforms: str | None,
    plots: bool,
    pdf: bool,
    svg: bool,
    dpi: int,
    max_panels: int | None,
    max_pages: int | None,
    figure_style: str | None,
    make_html: bool,
    evaluate: bool,
    align: str | None,
    rpe_lengths: str | None,
    show_outages: bool,
    stochastic: bool,
    imu_files: tuple[Path, ...],
    allan_tau: float,
) -> None:
    """Show the tables of a finished run (OUT, written by `coopproc run`) and remake its
    figures and HTML page, without recomputing anything.

    \b
    coopproc report out --table                 Table 2 and Table 3 in the terminal
    coopproc report out --axes                  and Table 3 per axis (E/N/U, velocity, attitude)
    coopproc report out --format latex -o t.tex LaTeX (booktabs) to a file
    coopproc report out --format latex --latex-width double --no-change
    coopproc report out --metrics max,rmse --pairs A-B
    coopproc report out --ci 0.9 --significance 0.01   90 % intervals, marks at p < 0.01
    coopproc report out --plots --pdf --html    figures (PNG + PDF) and report.html
    coopproc report out --plots --pairs A-B,A-C figures of two pairs only
    coopproc report out --plots --style single-column   one journal column wide
    coopproc report out --evaluate --align se3  3-D / vertical errors and RPE, evo-style
    coopproc report out --stochastic --plots    UWB noise model, IMU Allan deviation
    coopproc report out --outages               drift inside the run's UWB outages
    """
    from coopproc.io.outdir import (
        check_output_file,
        check_writable_dir,
        output_errors,
        write_text_atomic,
    )

    if output is not None:
        check_output_file(output)  # a mistyped directory fails before the work
    evaluate = evaluate or align is not None or rpe_lengths is not None
    alignments = _alignments(align)
    lengths = _lengths(rpe_lengths or "10,50,100")
    level = _level(ci, 0.95, "--ci")
    alpha = _level(significance, 0.05, "--significance")

    import matplotlib

    matplotlib.use("Agg")
    from coopproc.report.formats import format_tables
    from coopproc.report.rundir import load_run
    from coopproc.report.table_specs import run_labels

    run = load_run(out)
    click.get_current_context().with_resource(run_labels(run.info))  # its method names
    plots = plots or pdf or svg
    tau_given = click.get_current_context().get_parameter_source("allan_tau")
    stochastic = (
        stochastic or bool(imu_files) or tau_given == click.core.ParameterSource.COMMANDLINE
    )
    figure_options = None
    if plots or make_html:  # the pairs / platforms drawn (unknown ones fail before any work)
        from coopproc.report.pages import check_selection
        from coopproc.report.style import MAX_PANELS, STYLES

        figure_options = check_selection(
            run,
            comma_names(pairs),
            comma_names(platforms),
            max_panels or MAX_PANELS,
            STYLES[figure_style or "default"],
            _run_max_pages(run) if max_pages is None else max_pages,
        )
    if plots or make_html or stochastic:
        check_writable_dir(out, out)
    stoch = None
    if stochastic:  # UWB range residuals and IMU Allan deviation (coopproc/run/stochastic.py)
        from coopproc.run.stochastic import stochastic_report

        stoch = stochastic_report(out, run, imu_files=imu_files, allan_tau_s=allan_tau)
    if show_outages and run.outages is None:
        from coopproc.errors import InputError

        raise InputError(
            out / "outages.csv",
            "missing: the run had no outage windows (coopproc run --outage T0:T1, or "
            "[run] outages)",
        )
    asked = (
        stochastic
        or evaluate
        or show_outages
        or show_table
        or axes
        or fmt is not None
        or output is not None
    )
    if asked or not (plots or make_html):
        if stoch is not None:  # the stochastic tables instead of Table 2 / Table 3
            from coopproc.report.stochastic_format import format_stochastic

            text = format_stochastic(
                stoch,
                fmt or "terminal",
                latex_width=latex_width,  # type: ignore[arg-type]
            )
            if show_table:  # both when asked: Table 2/3 first
                tables = format_tables(
                    run,
                    fmt or "terminal",  # type: ignore[arg-type]
                    change=not no_change,
                    latex_width=latex_width,  # type: ignore[arg-type]
                )
                text = f"{tables}\n{text}"
        elif show_outages and run.outages is not None:  # drift inside the outage windows
            from coopproc.report.methods import position_methods
            from coopproc.report.outage import format_outages

            text = format_outages(
                run.outages,
                fmt or "terminal",  # type: ignore[arg-type]
                origin_s=_outage_origin(run),
                latex_width=latex_width,  # type: ignore[arg-type]
                order=("nav", *position_methods(run)),
            )
        elif evaluate:  # the evaluation tables instead of Table 2 / Table 3
            from coopproc.report.evaluation_tables import format_evaluation

            text = format_evaluation(
                run,
                fmt or "terminal",  # type: ignore[arg-type]
                align=alignments,
                segments_m=lengths,
                metrics=comma_names(metrics),
                platforms=comma_names(platforms),
                change=not no_change,
                latex_width=latex_width,  # type: ignore[arg-type]
            )
        else:
            text = format_tables(
                run,
                fmt or "terminal",  # type: ignore[arg-type]
                metrics=comma_names(metrics),
                pairs=comma_names(pairs),
                platforms=comma_names(platforms),
                change=not no_change,
                latex_width=latex_width,  # type: ignore[arg-type]
                axes=axes,
                level=level,
                significance=alpha,
            )
        if output is not None:
            write_text_atomic(output, text)
            click.echo(f"wrote {output}")
        else:
            click.echo(text, nl=False)
    if stoch is not None:  # files and notes on stderr: stdout may be a CSV being piped
        from coopproc.run.stochastic import write_stochastic

        kinds = ["png", *(["pdf"] if pdf else []), *(["svg"] if svg else [])] if plots else []
        for path in write_stochastic(out, stoch, formats=kinds, dpi=dpi, options=figure_options):
            click.echo(f"wrote {path}", err=True)
        for note in stoch.notes:
            click.echo(f"note: {note}", err=True)
    if plots:
        from coopproc.report.figures import write_figures

        formats = ["png", *(["pdf"] if pdf else []), *(["svg"] if svg else [])]
        cap_notes: list[str] = []  # what the page cap left out
        with output_errors(out):
            written = write_figures(
                run,
                out / "figures",
                formats=formats,
                dpi=dpi,
                options=figure_options,
                notes=cap_notes,
            )
        for path in written:
            click.echo(f"wrote {path}")
        for text in cap_notes:
            click.echo(
                f"note: {text.replace('coopproc report OUT', f'coopproc report {out}')}", err=True
            )
    if make_html:
        from coopproc.report.html import write_html

        with output_errors(out):
            html = write_html(out, run, stoch, figure_options)
        click.echo(f"wrote {html}")
