"""The ``coopproc`` command line: thin click commands over the library API.

Each command lives in its own module here, is listed in :mod:`coopproc.cli.commands`,
and is imported only when it runs, so that ``--version`` and ``--help`` start at once.
Errors: a :class:`~coopproc.errors.CoopprocError` becomes one ``error: ...`` line on
stderr and exit status 1 (2 for usage errors, as click does); ``--debug`` shows the
traceback instead. Any other exception is reported the same way as an internal error.
"""

from __future__ import annotations

import sys
from typing import Any

import click

from coopproc import __version__
from coopproc.cli.commands import LazyCommands
from coopproc.errors import CoopprocError

__all__ = ["main"]


class _Group(click.Group):
    """A click group that turns every error into one line unless ``--debug`` is given,
    with its commands imported on demand."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy_commands = LazyCommands()
        self.commands = self.lazy_commands

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The commands with their one-line help, without importing them."""
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(map(len, names))
        rows = [(name, self.lazy_commands.short_help(name, limit)) for name in names]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
            raise
        except CoopprocError as err:
            if ctx.obj and ctx.obj.get("debug"):
                raise
            click.echo(f"error: {err}", err=True)
            sys.exit(1)
        except KeyboardInterrupt:
            click.echo("interrupted", err=True)
            sys.exit(130)
        except Exception as err:
            if ctx.obj and ctx.obj.get("debug"):
                raise
            click.echo(
                f"error: internal error ({type(err).__name__}: {err}); "
                "run with --debug for the traceback and please report it",
                err=True,
            )
            sys.exit(1)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="coopproc")
@click.option("--debug", is_flag=True, help="Show Python tracebacks on errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Post-process recorded cooperative-positioning logs.

    \b
    coopproc run logs/ -o out/        readers -> stage chain -> CSV tables + figures
    coopproc report out/ --table      the paper tables in the terminal or as CSV/MD/LaTeX
    """
    ctx.ensure_object(dict)
    ctx.obj["debug"] = debug
