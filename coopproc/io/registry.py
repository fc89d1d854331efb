"""The registry of trajectory readers by file suffix, and discovery of a session's files.

A new trajectory format is one module plus one line in :data:`TRAJECTORY_READERS`.
Default names (DATA.md): ``nav_<ID>.<ext>``, ``ref_<ID>.<ext>``, ``ranges.csv[.gz]``,
``session.toml``, one ``*.mcap``; ``session.toml [files]`` maps other names.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from coopproc.errors import ConfigError, CoopprocError, InputError
from coopproc.io._common import RawTrajectory
from coopproc.io.csv_traj import read_traj_csv
from coopproc.io.rtklib_pos import read_pos
from coopproc.io.tum import read_tum
from coopproc.model import SessionConfig

__all__ = ["TRAJECTORY_READERS", "SessionFiles", "find_files", "read_trajectory", "suffix_of"]

TrajectoryReader = Callable[[Path, str], RawTrajectory]

#: File suffix -> reader(path, platform id). Longest suffix wins (``.csv.gz``).
TRAJECTORY_READERS: dict[str, TrajectoryReader] = {
    ".csv": read_traj_csv,
    ".csv.gz": read_traj_csv,
    ".tum": read_tum,
    ".pos": read_pos,
}

_NAME = re.compile(
    r"^(?P<kind>nav|ref)_(?P<id>[A-Za-z0-9_-]+?)(?P<ext>\.csv\.gz|\.csv|\.tum|\.pos)$"
)


def suffix_of(path: Path) -> str:
    """The registered suffix of ``path`` ('' when none matches)."""
    name = path.name.lower()
    for suffix in sorted(TRAJECTORY_READERS, key=len, reverse=True):
        if name.endswith(suffix):
            return suffix
    return ""


def read_trajectory(path: Path, platform: str) -> RawTrajectory:
    """Read a nav/ref file with the reader its suffix names."""
    suffix = suffix_of(path)
    if not suffix:
        raise InputError(
            path, f"unknown trajectory format; expected one of {', '.join(TRAJECTORY_READERS)}"
        )
    if not path.is_file():
        raise InputError(path, "no such file")
    return TRAJECTORY_READERS[suffix](path, platform)


@dataclass
class SessionFiles:
    """The input files of a session directory, by role."""

    nav: dict[str, Path] = field(default_factory=dict)
    ref: dict[str, Path] = field(default_factory=dict)
    ranges: Path | None = None
    mcap: Path | None = None
    problems: list[CoopprocError] = field(default_factory=list)


def find_files(root: Path, config: SessionConfig) -> SessionFiles:
    """Find the nav, ref, ranges and MCAP files of session directory ``root``."""
    out = SessionFiles()
    mapped = {root / name for name in config.files.values()}
    for path in sorted(root.iterdir()):
        m = _NAME.match(path.name)
        if not m or path in mapped or not path.is_file():
            continue
        target = out.nav if m["kind"] == "nav" else out.ref
        pid = m["id"]
        if pid in target:
            out.problems.append(
                InputError(path, f"second {m['kind']} file for {pid} (first: {target[pid].name})")
            )
            continue
        target[pid] = path
    for key, name in sorted(config.files.items()):
        path = root / name
        if not path.is_file():
            out.problems.append(ConfigError(f"session.toml [files] {key}: {name}: no such file"))
            continue
        if key == "ranges":
            out.ranges = path
        elif key == "mcap":
            out.mcap = path
        else:
            kind, pid = key.split(".", 1)
            (out.nav if kind == "nav" else out.ref)[pid] = path
    if out.ranges is None and "ranges" not in config.files:
        for name in ("ranges.csv", "ranges.csv.gz"):
            if (root / name).is_file():
                out.ranges = root / name
                break
    if out.mcap is None and "mcap" not in config.files:
        found = sorted(p for p in root.glob("*.mcap") if p.is_file())
        if len(found) > 1:
            names = ", ".join(p.name for p in found)
            out.problems.append(
                InputError(root, f"several MCAP files ({names}); expected one, or [files] mcap")
            )
        elif found:
            out.mcap = found[0]
    return out
