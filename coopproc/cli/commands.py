"""The registry of CLI commands: one module per command, one line each below."""

from __future__ import annotations

import importlib

import click

__all__ = ["load"]

#: (module under coopproc.cli, attribute) of every command.
COMMANDS: tuple[tuple[str, str], ...] = (
    # registry: add one line per command
    ("run", "run"),
    ("report", "report"),
    ("validate", "validate"),
    ("info", "info"),
    ("simulate", "simulate"),
    ("locate", "locate"),
    ("batch", "batch"),
    ("config_cmd", "config"),
)


def load() -> list[click.Command]:
    """Import every registered command."""
    commands = []
    for module_name, attribute in COMMANDS:
        module = importlib.import_module(f"coopproc.cli.{module_name}")
        commands.append(getattr(module, attribute))
    return commands
