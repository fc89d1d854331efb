"""``coopproc info SESSION``: platforms and roles, time span, rates, pairs, coverage, gaps."""

from __future__ import annotations

from pathlib import Path

import click

__all__ = ["info"]


@click.command()
@click.argument("session", type=click.Path(path_type=Path))
def info(session: Path) -> None:
    """Show what SESSION (a session directory or an .mcap file) holds.

    Platforms with roles, epochs, time span, rate and gaps, reference epochs and the
    share of the navigation span they cover; pairs with range counts, rates and gaps;
    and the notes of what the readers decided (defaults used, rows sorted, ...).
    """
    from coopproc.io import read_session
    from coopproc.io.info import format_info, session_info

    click.echo(format_info(session_info(read_session(session))))
