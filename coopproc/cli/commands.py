"""The registry of CLI commands: one module per command, one line each below.

A command's module is imported only when that command runs (or its own ``--help`` is
asked for), so ``coopproc --version`` and ``coopproc --help`` start without numpy,
pandas or scipy; the group's help lists each command with the summary given here.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, MutableMapping
from typing import NamedTuple

import click

__all__ = ["COMMANDS", "Entry", "LazyCommands", "load", "load_all"]


class Entry(NamedTuple):
    """A command: its module under coopproc.cli, the click command's attribute, and the
    first paragraph of its help (what ``coopproc --help`` shows; a test keeps the two
    equal)."""

    module: str
    attribute: str
    summary: str


#: Every command by name.
COMMANDS: dict[str, Entry] = {
    # registry: add one line per command
    "run": Entry(
        "run",
        "run",
        "Process a recorded session: clean the ranges, detect and estimate NLOS errors, "
        "fuse the positions, and write the tables, figures and report to OUT.",
    ),
    "report": Entry(
        "report",
        "report",
        "Show the tables of a finished run (OUT, written by `coopproc run`) and remake its "
        "figures and HTML page, without recomputing anything.",
    ),
    "export": Entry(
        "export",
        "export",
        "Write the trajectories of a finished run (OUT, written by `coopproc run`) as TUM, "
        "KITTI, RTKLIB .pos, GeoJSON or KML files, one per platform and method.",
    ),
    "validate": Entry(
        "validate",
        "validate",
        "Check SESSION (a session directory or an .mcap file) against the data contract.",
    ),
    "info": Entry(
        "info", "info", "Show what SESSION (a session directory or an .mcap file) holds."
    ),
    "simulate": Entry(
        "simulate",
        "simulate",
        "Simulate a session with known truth into OUT (session files + OUT/truth/).",
    ),
    "locate": Entry(
        "locate",
        "locate",
        "Localize TARGET (dead reckoning only, unknown start and azimuth) from its UWB "
        "ranges to one or more moving auxiliaries (paper 004): AACOPF, standard PF and EKF.",
    ),
    "batch": Entry(
        "batch",
        "batch",
        "Process many sessions, in parallel on Dask, each exactly as `coopproc run` would.",
    ),
    "inject": Entry(
        "inject",
        "inject",
        "Copy SESSION to NEW with NLOS errors, gross errors or UWB outages injected (listed "
        "in NEW/injected.csv), to score the methods on one's own recording.",
    ),
    "config": Entry(
        "config_cmd",
        "config",
        "Print the effective run configuration as TOML, each key with its help.",
    ),
    "spp": Entry(
        "spp",
        "spp",
        "GPS single-point positioning of OBS (RINEX 2/3 observations) with the broadcast "
        "ephemerides of NAV, written as an RTKLIB .pos file (Q = 5).",
    ),
}


def load(name: str) -> click.Command | None:
    """Import the command ``name`` (None if there is no such command)."""
    entry = COMMANDS.get(name)
    if entry is None:
        return None
    module = importlib.import_module(f"coopproc.cli.{entry.module}")
    command: click.Command = getattr(module, entry.attribute)
    return command


def load_all() -> dict[str, click.Command]:
    """Import every registered command (for tests and documentation tools)."""
    commands = {name: load(name) for name in COMMANDS}
    return {name: cmd for name, cmd in commands.items() if cmd is not None}


class LazyCommands(MutableMapping[str, click.Command]):
    """A click group's ``commands``: every registered name, imported on first access."""

    def __init__(self) -> None:
        self._names = list(COMMANDS)
        self._loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self._names:
            raise KeyError(name)
        if name not in self._loaded:
            command = load(name)
            if command is None:
                raise KeyError(name)
            self._loaded[name] = command
        return self._loaded[name]

    def __setitem__(self, name: str, command: click.Command) -> None:
        if name not in self._names:
            self._names.append(name)
        self._loaded[name] = command

    def __delitem__(self, name: str) -> None:
        self._names.remove(name)
        self._loaded.pop(name, None)

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._names))

    def __len__(self) -> int:
        return len(self._names)

    def short_help(self, name: str, limit: int) -> str:
        """The one-line help of ``name`` without importing it (the registry's summary)."""
        if name in self._loaded or name not in COMMANDS:
            return self[name].get_short_help_str(limit)
        # a bare command with the same help shortens it exactly as the real one would
        return click.Command(name, help=COMMANDS[name].summary).get_short_help_str(limit)
