"""``coopproc validate SESSION``: list every problem of a session (exit 1 when any)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from coopproc.io import validate_session

__all__ = ["validate"]


@click.command()
@click.argument("session", type=click.Path(path_type=Path))
@click.option("-q", "--quiet", is_flag=True, help="Print only the problems.")
def validate(session: Path, quiet: bool) -> None:
    """Check SESSION (a session directory or an .mcap file) against the data contract.

    Prints every problem found, one line each (file:line: what was found; what was
    expected), and exits 1 when there is any, 0 when the session is clean.
    """
    problems = validate_session(session)
    for line in problems:
        click.echo(line)
    if problems:
        if not quiet:
            click.echo(f"{len(problems)} problem(s) in {session}", err=True)
        sys.exit(1)
    if not quiet:
        click.echo(f"{session}: ok")
