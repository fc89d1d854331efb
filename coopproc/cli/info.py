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
    and the notes of what the readers decided (defaults used, rows sorted, ...). SESSION
    may also be a ROS bag (a .bag file or a ROS 2 bag folder); for a bag, or a session
    directory holding one, first its topics, types, counts and rates, and a [topics]
    mapping for session.toml; the session part follows when the mapping gives a
    complete session.
    """
    from coopproc.errors import CoopprocError
    from coopproc.io import read_session
    from coopproc.io.info import format_info, session_info
    from coopproc.io.rosbag_info import bag_report

    report = bag_report(session)
    if report is not None:
        click.echo(report)
        try:
            loaded = read_session(session)
        except CoopprocError as err:
            click.echo(f"\nnot a complete session yet: {err}")
            return
        click.echo("")
        click.echo(format_info(session_info(loaded)))
        return
    click.echo(format_info(session_info(read_session(session))))
