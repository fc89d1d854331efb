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
from coopproc.io.csv_forms import CsvForm
from coopproc.io.csv_traj import read_traj_csv
from coopproc.io.file_names import copy_id_note, default_ranges, unrecognised_note
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
    r"^(?P<kind>nav|ref)_(?P<id>[A-Za-z0-9_-]+?)(?P<ext>\.csv\.gz|\.csv|\.tum|\.pos)$",
    re.IGNORECASE,  # NAV_A.CSV too; the id keeps its case (file_names.py)
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


def read_trajectory(path: Path, platform: str, form: CsvForm | None = None) -> RawTrajectory:
    """Read a nav/ref file with the reader its suffix names (``form``: CSV readers)."""
    suffix = suffix_of(path)
    if not suffix:
        raise InputError(
            path, f"unknown trajectory format; expected one of {', '.join(TRAJECTORY_READERS)}"
        )
    if not path.is_file():
        raise InputError(path, "no such file")
    reader = TRAJECTORY_READERS[suffix]
    if form is not None and reader is read_traj_csv:
        return read_traj_csv(path, platform, form)
    return reader(path, platform)


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
    #: Files left out (copies, backups, names [files] replaces), one note each.
    notes: list[str] = field(default_factory=list)


def find_files(root: Path, config: SessionConfig) -> SessionFiles:
    """Find the nav, ref, ranges and MCAP files of session directory ``root``."""
    out = SessionFiles()
    mapped = {root / name for name in config.files.values()}
    unrecognised: list[Path] = []
    for path in sorted(root.iterdir()):
        m = _NAME.match(path.name)
        if not m and path not in mapped and path.is_file():
            sensor = _sensor_file(path)
            if sensor is not None:
                out.sensors.append(sensor)
            else:
                unrecognised.append(path)
        if not m or path in mapped or not path.is_file():
            continue
        kind = m["kind"].lower()
        target = out.nav if kind == "nav" else out.ref
        pid = m["id"]
        note = copy_id_note(path, pid, sorted(config.platforms))
        replaced = config.files.get(f"{kind}.{pid}")
        if replaced is not None:
            note = f"{path}: ignored: session.toml [files] {kind}.{pid} names {replaced}"
        if note is not None:
            out.notes.append(note)
            continue
        if pid in target:
            out.problems.append(
                InputError(path, f"second {kind} file for {pid} (first: {target[pid].name})")
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
        out.ranges, problem = default_ranges(root)
        out.problems.extend([problem] if problem else [])
    known = [p.name for p in (*out.nav.values(), *out.ref.values(), out.ranges) if p]
    for path in unrecognised:
        if path.name.lower() in ("ranges.csv", "ranges.csv.gz") and path != out.ranges:
            what = config.files.get("ranges", out.ranges.name if out.ranges else "")
            out.notes.append(f"{path}: ignored: the ranges are read from {what}")
            continue
        note = None if path == out.ranges else unrecognised_note(path, known)
        out.notes.extend([note] if note else [])
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
