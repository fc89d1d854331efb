"""``coopproc inject SESSION -o NEW``: NLOS, gross errors and outages injected into a copy."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from coopproc.cli.options import output_option, session_argument

__all__ = ["inject"]

#: What the hidden third value of --outage holds when no --pairs follows it.
_ALL = ""


class _InjectCommand(click.Command):
    """``--outage START END [--pairs P,...]``: a ``--pairs`` right after an ``--outage``
    belongs to it; it is folded into the outage's third (hidden) value before parsing."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        out: list[str] = []
        i = 0
        while i < len(args):
            token = args[i]
            if token == "--":
                out += args[i:]
                break
            if token == "--pairs" or token.startswith("--pairs="):
                raise click.UsageError("--pairs must follow an --outage START END", ctx)
            if token != "--outage":
                out.append(token)
                i += 1
                continue
            if len(args) < i + 3:
                raise click.UsageError("--outage needs START END", ctx)
            start, end, i = args[i + 1], args[i + 2], i + 3
            pairs = _ALL
            if i < len(args) and args[i] == "--pairs":
                if i + 1 >= len(args):
                    raise click.UsageError("--pairs needs a list of pairs, e.g. A-B,B-C", ctx)
                pairs, i = args[i + 1], i + 2
            elif i < len(args) and args[i].startswith("--pairs="):
                pairs, i = args[i].partition("=")[2], i + 1
            if pairs != _ALL and not pairs.strip(","):
                raise click.UsageError("--pairs needs a list of pairs, e.g. A-B,B-C", ctx)
            out += ["--outage", start, end, pairs]
        return super().parse_args(ctx, out)


@click.command(cls=_InjectCommand)
@session_argument()
@output_option(
    "out", "The new session directory (replaced only with --force).", required=True, metavar="NEW"
)
@click.option(
    "--nlos",
    multiple=True,
    nargs=5,
    type=(str, str, str, float, float),
    metavar="PAIR START END MEAN SD",
    help="NLOS errors drawn from N(MEAN, SD^2) (m), one per range of PAIR in [START, END] "
    "(paper 000 sec. 4.3). Repeatable.",
)
@click.option(
    "--gross",
    multiple=True,
    nargs=3,
    type=(str, str, float),
    metavar="PAIR TIME SIZE",
    help="A gross error of SIZE m on the range of PAIR nearest to TIME (paper 002 sec. 5.4). "
    "Repeatable.",
)
@click.option(
    "--outage",
    "outages",
    multiple=True,
    nargs=3,
    type=(str, str, str),
    metavar="START END [--pairs P,...]",
    help="Remove every range in [START, END], of every pair or of the --pairs that follow "
    "(paper 003 sec. 3.4). Repeatable.",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Seed of the NLOS draws (>= 0).",
)
@click.option("--force", is_flag=True, help="Replace NEW if it exists.")
def inject(
    session: Path,
    out: Path,
    nlos: tuple[tuple[str, str, str, float, float], ...],
    gross: tuple[tuple[str, str, float], ...],
    outages: tuple[tuple[str, str, str], ...],
    seed: int,
    force: bool,
) -> None:
    """Copy SESSION to NEW with NLOS errors, gross errors or UWB outages injected (listed
    in NEW/injected.csv), to score the methods on one's own recording.

    Times are in the session's time base, or +S for S seconds from the session start
    (`coopproc info SESSION` shows the span). `coopproc run NEW -o OUT` then writes
    OUT/injected_scores.csv (docs/inject.md).

    \b
    coopproc inject logs/ -o logs-nlos --nlos A-B +10 +20 0.45 0.1 --nlos B-C +50 +60 0.5 0.1
    coopproc inject logs/ -o logs-gross --gross A-B +30 2.0
    coopproc inject logs/ -o logs-out --outage +100 +130 --pairs A-B,A-C --seed 1
    """
    from coopproc.sim.inject import inject_session
    from coopproc.sim.inject_plan import (
        GrossInjection,
        Injection,
        NlosInjection,
        OutageInjection,
    )

    def pairs_of(text: str) -> tuple[str, ...]:
        return tuple(p.strip() for p in text.split(",") if p.strip())

    spec: dict[str, Any] = {
        "nlos": tuple(NlosInjection(*item) for item in nlos),
        "gross": tuple(GrossInjection(*item) for item in gross),
        "outages": tuple(OutageInjection(s, e, pairs_of(p)) for s, e, p in outages),
        "seed": seed,
    }
    result = inject_session(session, out, Injection(**spec), force=force)
    for note in result.notes:
        click.echo(f"note: {note}", err=True)
    click.echo(result.summary())
