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


def _chain_lines(cfg: Any, session: Any = None) -> list[str]:
    from coopproc.run.chain import chain_lines, resolve

    if session is None:
        lines = ["# the chain this runs (step: inputs -> outputs):"]
        lines += [f"#   {line}" for line in chain_lines(resolve(cfg.pipeline))]
        return [*lines, ""]
    from coopproc.run.session_chain import chain_report, resolve_session

    lines = [f"# the chain this runs on session {session.name} (step: inputs -> outputs):"]
    lines += [f"#   {line}" for line in chain_report(resolve_session(cfg, session))]
    return [*lines, ""]


def render_config(cfg: Any, session: Any = None) -> str:
    """The configuration as commented TOML that ``--config`` reads back, with the chain
    that ``[pipeline]`` resolves to (on ``session``, when given: with what the session's
    families add, each stage's required capabilities and the notes) as comments after
    that section."""
    lines: list[str] = []
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if isinstance(value, Mapping):  # the other registered stages' sections
            for name, params in value.items():
                lines.extend(_section_lines(name, params))
            continue
        lines.extend(_section_lines(f.name, value))
        if f.name == "pipeline":
            lines.extend(_chain_lines(cfg, session))
    return "\n".join(lines).rstrip() + "\n"


@click.command("config")
@config_option("A run configuration to merge over the defaults.")
@click.option(
    "--session",
    "session_path",
    type=click.Path(exists=True, path_type=Path),
    help="Resolve the chain for this session (directory or .mcap): the methods its "
    "tags, anchors, odometers, IMUs and GPS observations add, what each stage needs.",
)
def config(config_path: Path | None, session_path: Path | None) -> None:
    """Print the effective run configuration as TOML, each key with its help.

    Save it, edit it, and pass it to `coopproc run --config FILE`. With --session, the
    chain shown is the one `coopproc run` would run on that session.
    """
    from coopproc.run.config import load_run_config

    cfg = load_run_config(config_path)
    session = None
    if session_path is not None:
        from coopproc.checks.coverage import prepare_run
        from coopproc.io import read_session

        session, _ = prepare_run(read_session(session_path))
    click.echo(render_config(cfg, session), nl=False)
