"""Option bundles shared by several commands (one definition, one help text style)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

__all__ = [
    "comma_names",
    "config_option",
    "max_pages_option",
    "max_panels_option",
    "output_option",
    "session_argument",
    "style_option",
]

F = TypeVar("F", bound=Callable[..., Any])


def session_argument(**kwargs: Any) -> Callable[[F], F]:
    """SESSION: a session directory or .mcap file that exists."""
    return click.argument("session", type=click.Path(exists=True, path_type=Path), **kwargs)


def output_option(dest: str, help: str, **kwargs: Any) -> Callable[[F], F]:
    """``-o/--output DIR`` into parameter ``dest``."""
    return click.option(
        "-o", "--output", dest, type=click.Path(path_type=Path), help=help, **kwargs
    )


def config_option(help: str) -> Callable[[F], F]:
    """``-c/--config FILE`` (an existing TOML file) into parameter ``config_path``."""
    return click.option(
        "-c",
        "--config",
        "config_path",
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
        help=help,
    )


def comma_names(value: str | None) -> list[str] | None:
    """``--methods a,b`` style option values as a list (None: the option was not given)."""
    if value is None:
        return None
    names = [v.strip() for v in value.split(",") if v.strip()]
    if not names:
        raise click.BadParameter("expected a comma-separated list of names")
    return names


def max_panels_option() -> Callable[[F], F]:
    """``--max-panels N``: most panels on one figure page (None: the default, 24)."""
    return click.option(
        "--max-panels",
        type=click.IntRange(min=1),
        default=None,
        metavar="N",
        help="Most panels per figure page (default 24); more go on further pages "
        "(distance_errors.png, distance_errors_2.png, ...).",
    )


def max_pages_option(default_help: str) -> Callable[[F], F]:
    """``--max-pages N``: most pages a figure draws unless --pairs / --platforms chose
    (None: not given; 0: all)."""
    return click.option(
        "--max-pages",
        type=click.IntRange(min=0),
        default=None,
        metavar="N",
        help="Most pages a figure draws when --pairs / --platforms are not given; beyond, "
        "the pairs with the largest observed range RMSE, the platforms with the largest "
        f"position error, the largest NLOS events; 0: all (default: {default_help}).",
    )


#: The names of ``--style`` (:data:`coopproc.report.style.STYLES`; kept here so that the
#: CLI does not import matplotlib to list them; a test checks they agree).
STYLE_CHOICES = ("default", "single-column", "double-column")


def style_option(default_help: str = "default") -> Callable[[F], F]:
    """``--style NAME``: figure sizes and fonts (None: not given)."""
    return click.option(
        "--style",
        "figure_style",
        type=click.Choice(STYLE_CHOICES),
        default=None,
        help="Figure sizes and fonts: single-column (3.5 in wide, 8 pt), double-column "
        f"(7.16 in, 9 pt; IEEE page widths) or default ({default_help}); docs/report.md.",
    )
