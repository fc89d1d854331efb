"""``coopproc validate SESSION``: list every problem of a session (exit 1 when any)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

__all__ = ["validate"]


@click.command()
@click.argument("session", type=click.Path(path_type=Path))
@click.option(
    "--strict",
    is_flag=True,
    help="A single-row glitch of a navigation or reference file is a problem, not a row "
    "excluded with a note (as coopproc run --strict).",
)
@click.option("-q", "--quiet", is_flag=True, help="Print only the problems.")
def validate(session: Path, strict: bool, quiet: bool) -> None:
    """Check SESSION (a session directory or an .mcap file) against the data contract.

    Prints every problem found, one line each (file:line: what was found; what was
    expected), and exits 1 when there is any, 0 when the session is clean. A session
    that reads cleanly is also checked for what would spoil a run without being an
    error, printed as warnings (exit status 0): implausible jumps and accelerations of a
    platform's navigation or reference (docs/formats.md "Plausibility"), gaps in a
    platform's navigation, and
    navigation that starts after or ends before the ranges, with the count of ranges it
    does not cover, files left out (copies and backups such as nav_A_backup.csv), and
    files whose clock runs ahead of or behind the others' (estimated from the data,
    with its likely cause; docs/formats.md "Clock offsets"); and notes: every decision
    of the readers that coopproc run prints too (rows sorted, duplicates dropped,
    reference epochs dropped, a platform left out, defaults taken), raw-sensor files this
    version does not use, a platform whose navigation seems to be in a frame of its own,
    and clock offsets that are not observable or were applied.
    """
    from coopproc.checks.clock import clock_lines, prepared
    from coopproc.checks.coverage import coverage_warnings, session_start_s
    from coopproc.checks.framecheck import frame_notes
    from coopproc.io.plausible import WARNING
    from coopproc.io.raw_sensors import sensor_notes
    from coopproc.io.registry import find_files
    from coopproc.io.session import inspect_session

    data, problems = inspect_session(session, strict=strict)
    for line in problems:
        click.echo(line)
    if problems or data is None:
        if not quiet:
            click.echo(f"{len(problems)} problem(s) in {session}", err=True)
        sys.exit(1)
    if quiet:
        return
    data = prepared(data)  # clock offsets estimated ([time] offsets = "estimate": applied)
    coverage = coverage_warnings(data)
    if coverage:
        start = session_start_s(data)
        click.echo(f"note: times below are seconds from the session start, {start:.3f}")
    # implausible jumps and accelerations (io/plausible.py): warnings among the notes
    found = [n.removeprefix(WARNING) for n in data.notes if n.startswith(WARNING)]
    warnings = [*found, *coverage]
    if data.root.is_dir():  # copies and backups left out (io/file_names.py)
        warnings += find_files(data.root, data.config).notes
    assert data.clock is not None
    clock_warnings, clock_notes = clock_lines(data, data.clock)
    warnings += clock_warnings
    for line in warnings:
        click.echo(f"warning: {line}")
    # what the readers decided, as coopproc run prints it (rows sorted, duplicates
    # dropped, reference epochs dropped, a platform left out, defaults taken, [time.offsets]
    # applied, ...)
    notes = [n for n in data.notes if n not in warnings and not n.startswith(WARNING)]
    notes += [n for n in sensor_notes(data) if n not in notes]
    for note in [*notes, *frame_notes(data), *[n for n in clock_notes if n not in notes]]:
        click.echo(f"note: {note}")
    counted = f" ({len(warnings)} warning{'s' * (len(warnings) != 1)})" if warnings else ""
    click.echo(f"{session}: ok{counted}")
