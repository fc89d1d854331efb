"""``coopproc export OUT --format F -o DIR``: a finished run's trajectories for other tools."""

from __future__ import annotations

from pathlib import Path

import click

from coopproc.cli.options import comma_names

__all__ = ["export"]

#: The formats (kept here so that ``--help`` needs no numpy; a test keeps it equal to
#: coopproc.io.export.FORMATS).
FORMAT_NAMES = ("tum", "kitti", "pos", "geojson", "kml")


@click.command("export")
@click.argument("out", type=click.Path(path_type=Path, file_okay=False))
@click.option(
    "--format",
    "format_name",
    type=click.Choice(FORMAT_NAMES),
    required=True,
    help="tum (evo), kitti (+ times), pos (RTKLIB), geojson, kml.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path),
    required=True,
    help="Directory to write (created; replaced only with --force).",
)
@click.option("--methods", help="Methods to export, comma separated (default: all).")
@click.option("--platforms", help="Platforms to export, comma separated (default: all).")
@click.option("--force", is_flag=True, help="Replace the output directory if it exists.")
def export(
    out: Path,
    format_name: str,
    output: Path,
    methods: str | None,
    platforms: str | None,
    force: bool,
) -> None:
    """Write the trajectories of a finished run (OUT, written by `coopproc run`) as TUM,
    KITTI, RTKLIB .pos, GeoJSON or KML files, one per platform and method.

    Every method of positions.csv is exported (the fused ones, `nav` and `reference`)
    unless --methods says which; files are DIR/<platform>.<method>.<ext> (ext: tum,
    kitti.txt with <platform>.<method>.times.txt beside it, pos, geojson, kml). The
    geodetic formats need the session's ENU origin ([frame] origin), .pos also GPS or
    Unix times. OUT is never modified. See docs/export.md.

    \b
    coopproc export out --format tum -o traj            every platform and method
    coopproc export out --format pos -o pos --methods di,reference
    coopproc export out --format geojson -o map --platforms A
    """
    from coopproc.io.export import check_export_dir, export_tracks, run_frame, select_tracks
    from coopproc.report.rundir import load_run

    check_export_dir(output, out, force=force)  # before reading the run
    run = load_run(out)
    frame = run_frame(run.info, out / "run.json")
    tracks, notes = select_tracks(
        run.positions, methods=comma_names(methods), platforms=comma_names(platforms)
    )
    for note in notes:
        click.echo(f"note: {note}", err=True)
    written = export_tracks(tracks, output, format_name, frame, run_dir=out, force=force)
    for path in written:
        click.echo(f"wrote {path}")
