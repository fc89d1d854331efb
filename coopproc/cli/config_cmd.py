"""``coopproc config``: print the effective run configuration, every key with its help."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import click

from coopproc.cli.options import config_option

__all__ = ["config"]


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if value is None:
        return '"auto"'
    return repr(value)


def _section_lines(name: str, obj: Any) -> list[str]:
    lines = [f"[{name}]"]
    subsections = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            subsections.append((f"{name}.{f.name}", value))
            continue
        help_text = str(f.metadata.get("help", ""))
        if help_text:
            lines.append(f"# {help_text}")
        if value is None:
            lines.append(f"# {f.name} = (not set: {help_text or 'default'})")
        else:
            lines.append(f"{f.name} = {_toml_value(value)}")
    out = [*lines, ""]
    for sub_name, sub in subsections:
        out.extend(_section_lines(sub_name, sub))
    return out


def _chain_lines(cfg: Any) -> list[str]:
    from coopproc.run.chain import chain_lines, resolve

    lines = ["# the chain this runs (step: inputs -> outputs):"]
    lines += [f"#   {line}" for line in chain_lines(resolve(cfg.pipeline))]
    return [*lines, ""]


def render_config(cfg: Any) -> str:
    """The configuration as commented TOML that ``--config`` reads back, with the chain
    that ``[pipeline]`` resolves to as comments after that section."""
    lines: list[str] = []
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if isinstance(value, Mapping):  # the other registered stages' sections
            for name, params in value.items():
                lines.extend(_section_lines(name, params))
            continue
        lines.extend(_section_lines(f.name, value))
        if f.name == "pipeline":
            lines.extend(_chain_lines(cfg))
    return "\n".join(lines).rstrip() + "\n"


@click.command("config")
@config_option("A run configuration to merge over the defaults.")
def config(config_path: Path | None) -> None:
    """Print the effective run configuration as TOML, each key with its help.

    Save it, edit it, and pass it to `coopproc run --config FILE`.
    """
    from coopproc.run.config import load_run_config

    click.echo(render_config(load_run_config(config_path)), nl=False)
