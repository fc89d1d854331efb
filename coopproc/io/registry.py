"""The registry of trajectory readers by file suffix, and discovery of a session's files.

A new trajectory format is one module plus one line in :data:`TRAJECTORY_READERS`.
Default names (DATA.md): ``nav_<ID>.<ext>``, ``ref_<ID>.<ext>``, ``ranges.csv[.gz]``,
``session.toml``, one ``*.mcap``; ``session.toml [files]`` maps other names. The
raw-sensor files of DATA.md "Raw sensors" (``imu_<ID>.csv``, ``odo_<ID>.csv``, RINEX
observations and broadcast navigation) are recognised and listed, not read.
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
from coopproc.model import SensorFile, SessionConfig

__all__ = [
    "SENSOR_KINDS",
    "TRAJECTORY_READERS",
    "SessionFiles",
    "find_files",
    "read_trajectory",
    "sensor_note",
    "suffix_of",
]

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


_ID = r"(?P<id>[A-Za-z0-9_-]+?)"
#: Raw-sensor file names (DATA.md "Raw sensors") -> kind; ``.gz`` compressed too.
_SENSOR_NAMES: tuple[tuple[re.Pattern[str], str], ...] = (
    (re.compile(rf"^imu_{_ID}\.csv(\.gz)?$"), "imu"),
    (re.compile(rf"^odo_{_ID}\.csv(\.gz)?$"), "odo"),
    (re.compile(rf"^obs_{_ID}\.(\d\d[oO]|rnx)(\.gz)?$"), "gnss_obs"),
    (re.compile(r"^(nav\.rnx|.+_MN\.rnx|.+\.\d\d[nN])(\.gz)?$"), "gnss_nav"),
)
#: What each kind of raw-sensor file holds, for the notes.
SENSOR_KINDS: dict[str, str] = {
    "imu": "IMU samples",
    "odo": "odometer speeds",
    "gnss_obs": "GNSS observations (RINEX)",
    "gnss_nav": "GNSS broadcast ephemerides (RINEX navigation)",
}


def _sensor_file(path: Path) -> SensorFile | None:
    for pattern, kind in _SENSOR_NAMES:
        m = pattern.match(path.name)
        if m:
            pid = m.groupdict().get("id")
            return SensorFile(kind, path, pid)  # type: ignore[arg-type]
    return None


def sensor_note(sensor: SensorFile) -> str:
    """The one note a raw-sensor file gets: recognised, not used by this version."""
    whose = f" of {sensor.platform}" if sensor.platform is not None else ""
    return (
        f"{sensor.path}: {SENSOR_KINDS[sensor.kind]}{whose} recognised but not used by "
        "this version of coopproc"
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
    #: Raw-sensor files (listed, not read).
    sensors: list[SensorFile] = field(default_factory=list)
    problems: list[CoopprocError] = field(default_factory=list)


def find_files(root: Path, config: SessionConfig) -> SessionFiles:
    """Find the nav, ref, ranges and MCAP files of session directory ``root``."""
    out = SessionFiles()
    mapped = {root / name for name in config.files.values()}
    for path in sorted(root.iterdir()):
        m = _NAME.match(path.name)
        if not m and path not in mapped and path.is_file():
            sensor = _sensor_file(path)
            if sensor is not None:
                out.sensors.append(sensor)
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
