"""``coopproc report OUT``: the paper's tables, figures and HTML page from a finished run."""

from __future__ import annotations

from pathlib import Path

import click

__all__ = ["report"]


def _names(value: str | None) -> list[str] | None:
    if value is None:
        return None
    names = [v.strip() for v in value.split(",") if v.strip()]
    if not names:
        raise click.BadParameter("expected a comma-separated list of names")
    return names


@click.command("report")
@click.argument("out", type=click.Path(path_type=Path, file_okay=False))
@click.option("--table", "show_table", is_flag=True, help="Print Table 2 and Table 3 (default).")
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
@click.option("--metrics", help="Columns to show, comma separated (e.g. max,rmse,snr_db).")
@click.option("--pairs", help="Pairs to show in Table 2, comma separated (e.g. A-B,B-C).")
@click.option("--platforms", help="Platforms to show in Table 3, comma separated.")
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
@click.option("--html", "make_html", is_flag=True, help="Write OUT/report.html.")
def report(
    out: Path,
    show_table: bool,
    fmt: str | None,
    output: Path | None,
    metrics: str | None,
    pairs: str | None,
    platforms: str | None,
    plots: bool,
    pdf: bool,
    svg: bool,
    dpi: int,
    make_html: bool,
) -> None:
    """Show the tables of a finished run (OUT, written by `coopproc run`) and remake its
    figures and HTML page, without recomputing anything.

    \b
    coopproc report out --table                 Table 2 and Table 3 in the terminal
    coopproc report out --format latex -o t.tex LaTeX (booktabs) to a file
    coopproc report out --metrics max,rmse --pairs A-B
    coopproc report out --plots --pdf --html    figures (PNG + PDF) and report.html
    """
    from coopproc.io.outdir import (
        check_output_file,
        check_writable_dir,
        output_errors,
        write_text_atomic,
    )

    if output is not None:
        check_output_file(output)  # a mistyped directory fails before the work

    import matplotlib

    matplotlib.use("Agg")
    from coopproc.report.formats import format_tables
    from coopproc.report.rundir import load_run

    run = load_run(out)
    plots = plots or pdf or svg
    if plots or make_html:
        check_writable_dir(out, out)
    if show_table or fmt is not None or output is not None or not (plots or make_html):
        text = format_tables(
            run,
            fmt or "terminal",  # type: ignore[arg-type]
            metrics=_names(metrics),
            pairs=_names(pairs),
            platforms=_names(platforms),
        )
        if output is not None:
            write_text_atomic(output, text)
            click.echo(f"wrote {output}")
        else:
            click.echo(text, nl=False)
    if plots:
        from coopproc.report.figures import write_figures

        formats = ["png", *(["pdf"] if pdf else []), *(["svg"] if svg else [])]
        with output_errors(out):
            written = write_figures(run, out / "figures", formats=formats, dpi=dpi)
        for path in written:
            click.echo(f"wrote {path}")
    if make_html:
        from coopproc.report.html import write_html

        with output_errors(out):
            html = write_html(out, run)
        click.echo(f"wrote {html}")
