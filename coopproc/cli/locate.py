"""``coopproc locate SESSION --target ID --aux ID[,ID] -o OUT``: paper 004 localization."""

from __future__ import annotations

import tomllib
from pathlib import Path

import click

from coopproc.cli.options import config_option, output_option, session_argument, style_option
from coopproc.errors import ConfigError

__all__ = ["locate"]


def _read_config(path: Path | None) -> dict[str, object]:
    """The ``[locate]`` table of a TOML file (the whole file if it has no such table)."""
    if path is None:
        return {}
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ConfigError(f"{path}: cannot read the configuration: {err}") from err
    table = data.get("locate", data)
    if not isinstance(table, dict):
        raise ConfigError(f"{path} [locate]: expected a table")
    return table


@click.command()
@session_argument()
@click.option("--target", required=True, help="Id of the platform to localize.")
@click.option("--aux", "aux", required=True, help="Auxiliary platform id(s), comma separated.")
@output_option("out_dir", "Output directory (replaced only with --force).", required=True)
@config_option("TOML file with a [locate] table (N, M, alpha, beta, lambda, Omega1, ...).")
@click.option("--force", is_flag=True, help="Replace an existing output directory.")
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=None,
    help="Random seed, 0 or more (overrides the config).",
)
@click.option("--no-figures", is_flag=True, help="Write the tables only.")
@style_option()
def locate(
    session: Path,
    target: str,
    aux: str,
    out_dir: Path,
    config_path: Path | None,
    force: bool,
    seed: int | None,
    no_figures: bool,
    figure_style: str | None,
) -> None:
    """Localize TARGET (dead reckoning only, unknown start and azimuth) from its UWB
    ranges to one or more moving auxiliaries (paper 004): AACOPF, standard PF and EKF.

    Writes OUT/locate.csv, OUT/locate_summary.csv, OUT/observability.csv and
    OUT/figures/; see docs/locate.md.
    """
    from coopproc.io.outdir import atomic_output_dir, check_output_dir

    # before the imports and the work: a read-only or mistyped OUT fails at once
    check_output_dir(out_dir, force=force, protect=[session])

    import math
    import sys

    import matplotlib

    matplotlib.use("Agg")

    from coopproc.io import read_session
    from coopproc.io.outdir import write_csv
    from coopproc.report.locate_figures import write_locate_figures
    from coopproc.report.style import STYLES
    from coopproc.stages.particle import (
        LOCATE_COLUMNS,
        LOCATE_SUMMARY_COLUMNS,
        locate_params,
        observability_table,
        with_seed,
    )
    from coopproc.stages.particle import locate as run_locate
    from coopproc.stages.particle.progress import EpochProgress

    params = with_seed(locate_params(_read_config(config_path), f"{config_path} [locate]"), seed)
    aux_ids = [a.strip() for a in aux.split(",") if a.strip()]
    data = read_session(session)
    # progress on stderr: a bar per method on a terminal, else a line per tenth of it
    progress = EpochProgress(bar=sys.stderr.isatty(), log=lambda text: click.echo(text, err=True))
    try:
        result = run_locate(data, target, aux_ids, params, progress=progress)
    finally:
        progress.close()
    for warning in result.warnings:
        click.echo(f"warning: {warning}", err=True)
    with atomic_output_dir(out_dir, force=force, protect=[session]) as tmp:
        write_csv(result.table, tmp / "locate.csv", LOCATE_COLUMNS)
        write_csv(result.summary, tmp / "locate_summary.csv", LOCATE_SUMMARY_COLUMNS)
        write_csv(observability_table(result), tmp / "observability.csv")
        if not no_figures:
            write_locate_figures(result, tmp / "figures", style=STYLES[figure_style or "default"])
    for row in result.summary.to_dict("records"):
        az_err = float(row["azimuth_error"])
        rmse = float(row["rmse_h"])
        err = "" if math.isnan(az_err) else f" ({az_err:+.2f})"
        rmse_text = "-" if math.isnan(rmse) else f"{rmse:.3f} m"
        click.echo(
            f"{row['method']:>6}: initial azimuth {float(row['initial_azimuth']):.2f} deg{err}, "
            f"rmse_h {rmse_text}, observable {int(row['observable'])}"
        )
    click.echo(f"wrote {out_dir}")
