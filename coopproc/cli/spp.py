"""``coopproc spp OBS --nav NAV -o OUT.pos``: GPS single-point positioning of a RINEX file."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

__all__ = ["spp"]


class _Progress:
    """A bar on a terminal, else one stderr line per tenth of the epochs (long files)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.bar = sys.stderr.isatty()
        self.start = time.perf_counter()
        self.next_tenth = 1

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or total < 2000:
            return
        if self.bar:
            width = 30
            filled = width * done // total
            sys.stderr.write(f"\rspp [{'#' * filled}{'.' * (width - filled)}] {done}/{total}")
            if done == total:
                sys.stderr.write("\n")
            sys.stderr.flush()
            return
        while done * 10 >= self.next_tenth * total and self.next_tenth < 10:
            click.echo(
                f"spp: {10 * self.next_tenth}% ({done}/{total} epochs, "
                f"{time.perf_counter() - self.start:.1f} s)",
                err=True,
            )
            self.next_tenth += 1


@click.command("spp")
@click.argument("obs", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--nav",
    "navs",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    multiple=True,
    required=True,
    help="RINEX navigation file (GPS broadcast ephemerides); repeat for several.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="The RTKLIB .pos file to write (replaced if it exists).",
)
@click.option(
    "--elevation-mask",
    type=click.FloatRange(0.0, 90.0, max_open=True),
    default=10.0,
    show_default=True,
    metavar="DEG",
    help="Satellites below this elevation are not used.",
)
@click.option("--no-iono", is_flag=True, help="No ionosphere model (Klobuchar by default).")
@click.option("--no-tropo", is_flag=True, help="No troposphere model (Saastamoinen by default).")
@click.option(
    "--raim",
    is_flag=True,
    help="Chi-square test of each epoch's residuals; exclude the worst satellite and retest "
    "(epochs still failing get no solution).",
)
@click.option("--quiet", is_flag=True, help="No progress and no summary line.")
def spp(
    obs: Path,
    navs: tuple[Path, ...],
    output: Path,
    elevation_mask: float,
    no_iono: bool,
    no_tropo: bool,
    raim: bool,
    quiet: bool,
) -> None:
    """GPS single-point positioning of OBS (RINEX 2/3 observations) with the broadcast
    ephemerides of NAV, written as an RTKLIB .pos file (Q = 5).

    Per epoch: weighted least squares on position and receiver clock from the L1 code
    pseudoranges, with satellite clock, relativity, TGD, earth rotation, Klobuchar
    ionosphere and Saastamoinen troposphere; see docs/methods-gnss.md.
    """
    from coopproc.errors import InputError
    from coopproc.io.outdir import check_output_file

    check_output_file(output)

    from coopproc.gnss.pos_write import write_spp_pos
    from coopproc.gnss.rinex_nav import read_navs
    from coopproc.gnss.rinex_obs import read_obs
    from coopproc.gnss.spp import SppOptions, solve_spp

    ephemerides = read_navs(list(navs))
    observations = read_obs(obs)
    options = SppOptions(
        elevation_mask_deg=elevation_mask, iono=not no_iono, tropo=not no_tropo, raim=raim
    )
    solution = solve_spp(observations, ephemerides, options, progress=_Progress(not quiet))
    if solution.time_gpst_s.size == 0:
        reasons = ", ".join(f"{k}: {v}" for k, v in solution.no_solution.items())
        raise InputError(obs, f"no epoch has a solution ({reasons})")
    header = [
        f"inp file  : {obs}",
        *(f"inp file  : {n}" for n in navs),
        f"elev mask : {elevation_mask:g} deg",
        f"ionos opt : {'off' if no_iono else 'broadcast'}",
        f"tropo opt : {'off' if no_tropo else 'saastamoinen'}",
        f"raim      : {'on' if raim else 'off'}",
    ]
    write_spp_pos(output, solution, header)
    if quiet:
        return
    missing = solution.epochs - solution.time_gpst_s.size
    why = (
        ""
        if not missing
        else " (" + ", ".join(f"{k}: {v}" for k, v in solution.no_solution.items()) + ")"
    )
    click.echo(
        f"spp: {solution.time_gpst_s.size} of {solution.epochs} epochs solved{why}, "
        f"{len(solution.excluded)} satellite(s) excluded by RAIM; wrote {output}"
    )
