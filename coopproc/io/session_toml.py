"""session.toml: every key of DATA.md plus ``[reference]``, ``[files]`` and ``[mcap]``.

Every key is optional; an unknown key (or table) is a ConfigError naming the nearest
valid one. The tables and their defaults are the dataclasses below (one help line each);
``docs/formats.md`` lists them. Reading and writing the whole document is here; the
``[platforms.<ID>]`` tables, with the raw-sensor keys of a platform (DATA.md "Raw
sensors": wheelbase, lever arms, IMU mounting, NHC, ``[platforms.ID.imu]``, read and
checked into :class:`~coopproc.model.Platform`; no stage uses them yet), are
:mod:`coopproc.io.session_platforms`.
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import tomli_w

from coopproc.configtools import check_keys, from_table
from coopproc.errors import ConfigError, InputError
from coopproc.io._common import ID_PATTERN, one_line
from coopproc.io.csv_mapping import ENCODING_KEYS, CsvForms, parse_columns, parse_encodings
from coopproc.io.session_platforms import (
    IMU_GRADES,
    ImuTable,
    PlatformTable,
    parse_platforms,
    platform_entry,
)
from coopproc.io.topics_toml import TopicsMapping, parse_topics
from coopproc.model import SessionConfig

__all__ = [
    "IMU_GRADES",
    "McapMapping",
    "TomlRead",
    "describe_keys",
    "mcap_mapping",
    "parse_session_toml",
    "read_session_toml",
    "session_toml_table",
    "write_session_toml",
]


@dataclass(frozen=True)
class _SessionTable:
    name: str = field(default="", metadata={"help": "free text name of the recording"})


@dataclass(frozen=True)
class _TimeTable:
    base: Literal["gps_tow", "unix", "relative"] | None = field(
        default=None,
        metadata={"help": "time base of every file: gps_tow | unix | relative (absent: inferred)"},
    )
    gps_week: int | None = field(
        default=None,
        metadata={"help": "GPS week of gps_tow times (absent: the week of the first .pos epoch)"},
    )


@dataclass(frozen=True)
class _FrameTable:
    origin: tuple[float, float, float] | None = field(
        default=None, metadata={"help": "lat deg, lon deg, height m of the ENU origin"}
    )


@dataclass(frozen=True)
class _UwbTable:
    sigma: float | None = field(
        default=None, metadata={"help": "ranging 1-sigma, metres (absent: estimated)"}
    )


@dataclass(frozen=True)
class _CalibrationTable:
    trust_declared: bool = field(
        default=False,
        metadata={
            "help": "keep a follower's drift_sigma even where the data contradict it by "
            "more than 10 x (false: replaced by the estimate, with a note)"
        },
    )


@dataclass(frozen=True)
class _ReferenceTable:
    quality: tuple[int, ...] = field(
        default=(1,), metadata={"help": "RTKLIB Q values used as reference (1 = fix)"}
    )


@dataclass(frozen=True)
class McapMapping:
    """The ``[mcap]`` table: topics (``{id}`` = platform id) and range message fields."""

    nav_topic: str = field(default="/{id}/nav", metadata={"help": "navigation topic template"})
    reference_topic: str = field(
        default="/{id}/reference", metadata={"help": "reference topic template"}
    )
    range_topic: str = field(default="/uwb/range", metadata={"help": "UWB range topic"})
    imu_topic: str = field(
        default="/{id}/imu", metadata={"help": "raw IMU topic template (sensor_msgs/msg/Imu)"}
    )
    odometer_topic: str = field(
        default="/{id}/odometer",
        metadata={"help": "odometer topic template (nav_msgs/msg/Odometry twist)"},
    )
    from_field: str = field(default="from", metadata={"help": "range message: id of one end"})
    to_field: str = field(default="to", metadata={"help": "range message: id of the other end"})
    range_field: str = field(default="range", metadata={"help": "range message: range, metres"})
    sigma_field: str = field(default="sigma", metadata={"help": "range message: 1-sigma, m"})


_TABLES: dict[str, type] = {
    "session": _SessionTable,
    "time": _TimeTable,
    "frame": _FrameTable,
    "uwb": _UwbTable,
    "reference": _ReferenceTable,
    "calibration": _CalibrationTable,
    "mcap": McapMapping,
}
_TOP = (*_TABLES, "platforms", "files", "columns", "topics")
_FILE_KEYS = ("ranges", "mcap", "nav", "ref", *ENCODING_KEYS)


def mcap_mapping(config: SessionConfig) -> McapMapping:
    """The ``[mcap]`` mapping of a config (defaults for keys not given)."""
    return from_table(McapMapping, dict(config.mcap), "session.toml [mcap]")


@dataclass(frozen=True)
class TomlRead:
    """A parsed session.toml and which defaults it left open."""

    config: SessionConfig
    base_given: bool
    #: Where it was read from (a path, or an MCAP file's attachment), for messages.
    source: str = "session.toml"
    #: Encodings, column names and units of the CSV files ([files] encoding, [columns]).
    forms: CsvForms = field(default_factory=CsvForms)
    #: The ``[topics]`` mapping of a ROS bag session (None: absent), topics_toml.py.
    topics: TopicsMapping | None = None


def parse_session_toml(text: str, where: str = "session.toml") -> TomlRead:
    """Parse session.toml text; raises ConfigError (keys, values) or InputError (syntax)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(where, f"not valid TOML: {one_line(err)}") from err
    check_keys(doc, _TOP, where)
    time_doc = doc.get("time")
    offsets: Any = {}
    if isinstance(time_doc, Mapping) and "offsets" in time_doc:
        time_doc = dict(time_doc)
        offsets = _offsets(time_doc.pop("offsets"), where)
    tables: dict[str, Any] = {}
    for name, cls in _TABLES.items():
        table = time_doc if name == "time" else doc.get(name)
        tables[name] = from_table(cls, table, f"{where} [{name}]")
    time_t: _TimeTable = tables["time"]
    if time_t.gps_week is not None and not 0 <= time_t.gps_week < 10000:
        raise ConfigError(f"{where} [time] gps_week: {time_t.gps_week}; expected 0..9999")
    origin = tables["frame"].origin
    if origin is not None and (abs(origin[0]) > 90 or abs(origin[1]) > 360):
        raise ConfigError(f"{where} [frame] origin: {list(origin)}; expected [lat, lon, height]")
    uwb_sigma = tables["uwb"].sigma
    if uwb_sigma is not None and not uwb_sigma > 0:
        raise ConfigError(f"{where} [uwb] sigma: {uwb_sigma}; expected a positive number")
    quality = tables["reference"].quality
    if not quality:
        raise ConfigError(f"{where} [reference] quality: empty; expected e.g. [1] or [1, 2]")
    platforms = parse_platforms(doc.get("platforms", {}), where)
    files = _files(doc.get("files", {}), where)
    encoding, encodings = parse_encodings(doc.get("files", {}), where)
    columns, units = parse_columns(doc.get("columns", {}), where)
    forms = CsvForms(encoding, encodings, columns, units)
    config = SessionConfig(
        name=tables["session"].name,
        time_base=time_t.base or "gps_tow",
        gps_week=time_t.gps_week,
        origin_llh=origin,
        platforms=platforms,
        uwb_sigma_m=uwb_sigma,
        reference_quality=tuple(quality),
        files=files,
        mcap=dict(doc.get("mcap", {})),
        time_offsets=offsets,
        trust_declared=bool(tables["calibration"].trust_declared),
    )
    topics = parse_topics(doc.get("topics"), where)
    return TomlRead(
        config, base_given=time_t.base is not None, source=where, forms=forms, topics=topics
    )


def _offsets(value: Any, where: str) -> Literal["estimate"] | dict[str, float]:
    """``[time] offsets``: "estimate", or ``[time.offsets]`` ``ranges`` / ``nav.<ID>`` /
    ``ref.<ID>`` = seconds the file's times run ahead (subtracted on reading)."""
    if value == "estimate":
        return "estimate"
    expected = (
        'expected "estimate" or a table [time.offsets] with ranges, nav.<ID>, ref.<ID> = '
        "seconds the file's times run ahead"
    )
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where} [time] offsets: {value!r}; {expected}")
    check_keys(value, ("ranges", "nav", "ref"), f"{where} [time.offsets]")
    out: dict[str, float] = {}
    for key, item in value.items():
        entries = {key: item} if key == "ranges" else item
        if key != "ranges" and not isinstance(item, Mapping):
            raise ConfigError(f"{where} [time.offsets] {key}: {item!r}; {expected}")
        for name, seconds in entries.items():
            full = name if key == "ranges" else f"{key}.{name}"
            if key != "ranges" and not ID_PATTERN.match(name):
                raise ConfigError(f"{where} [time.offsets] {full}: not a platform id; {expected}")
            if isinstance(seconds, bool) or not isinstance(seconds, int | float):
                raise ConfigError(f"{where} [time.offsets] {full}: {seconds!r}; {expected}")
            if not abs(float(seconds)) < 1e6:
                raise ConfigError(
                    f"{where} [time.offsets] {full}: {seconds!r}; expected seconds, |s| < 1e6"
                )
            out[full] = float(seconds)
    return out


def _files(table: Any, where: str) -> dict[str, str]:
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where} [files]: expected a table")
    check_keys(table, _FILE_KEYS, f"{where} [files]")
    out: dict[str, str] = {}
    for key, value in table.items():
        if key in ENCODING_KEYS:
            continue  # csv_mapping.parse_encodings
        if key in ("nav", "ref"):
            if not isinstance(value, Mapping):
                raise ConfigError(f'{where} [files] {key}: expected a table {key}.<ID> = "file"')
            for pid, name in value.items():
                if not isinstance(name, str) or not ID_PATTERN.match(pid):
                    raise ConfigError(
                        f'{where} [files.{key}] {pid}: expected <platform id> = "file name"'
                    )
                out[f"{key}.{pid}"] = name
        elif isinstance(value, str):
            out[key] = value
        else:
            raise ConfigError(f"{where} [files] {key}: expected a file name string")
    for name in out.values():
        if Path(name).is_absolute() or ".." in Path(name).parts or re.search(r"[\x00]", name):
            raise ConfigError(
                f"{where} [files]: {name!r}; expected a path relative to the session directory"
            )
    return out


def read_session_toml(path: str | Path) -> TomlRead:
    """Read a session.toml file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeError) as err:
        raise InputError(p, f"cannot read ({type(err).__name__}); expected UTF-8 TOML") from err
    return parse_session_toml(text, str(p))


def session_toml_table(
    config: SessionConfig, origin_llh: tuple[float, float, float] | None = None
) -> dict[str, Any]:
    """The TOML document of a config (only keys that differ from the defaults)."""
    doc: dict[str, Any] = {}
    if config.name:
        doc["session"] = {"name": config.name}
    time: dict[str, Any] = {"base": config.time_base}
    if config.gps_week is not None:
        time["gps_week"] = config.gps_week
    if config.time_offsets == "estimate":
        time["offsets"] = "estimate"
    elif config.time_offsets:
        table: dict[str, Any] = {}
        for key, seconds in config.time_offsets.items():
            kind, _, pid = key.partition(".")
            if pid:
                table.setdefault(kind, {})[pid] = seconds
            else:
                table[key] = seconds
        time["offsets"] = table
    doc["time"] = time
    origin = origin_llh or config.origin_llh
    if origin is not None:
        doc["frame"] = {"origin": [float(v) for v in origin]}
    if config.platforms:
        platforms: dict[str, Any] = {}
        for pid in sorted(config.platforms):
            platforms[pid] = platform_entry(config.platforms[pid])
        doc["platforms"] = platforms
    if config.uwb_sigma_m is not None:
        doc["uwb"] = {"sigma": config.uwb_sigma_m}
    if tuple(config.reference_quality) != (1,):
        doc["reference"] = {"quality": list(config.reference_quality)}
    if config.trust_declared:
        doc["calibration"] = {"trust_declared": True}
    if config.mcap:
        doc["mcap"] = dict(config.mcap)
    return doc


def write_session_toml(
    config: SessionConfig, path: str | Path, origin_llh: tuple[float, float, float] | None = None
) -> Path:
    """Write session.toml for ``config`` (``[files]`` is not written: default names)."""
    p = Path(path)
    p.write_text(tomli_w.dumps(session_toml_table(config, origin_llh)), encoding="utf-8")
    return p


# Keep the field list in one place for docs: (table, key, default, help).
def describe_keys() -> list[tuple[str, str, object, str]]:
    """Every session.toml key: (table, key, default, help)."""
    rows: list[tuple[str, str, object, str]] = []
    for name, cls in _TABLES.items():
        for f in dataclasses.fields(cls):
            rows.append((name, f.name, f.default, str(f.metadata.get("help", ""))))
    for f in dataclasses.fields(PlatformTable):
        rows.append(("platforms.<ID>", f.name, f.default, str(f.metadata.get("help", ""))))
    for f in dataclasses.fields(ImuTable):
        rows.append(("platforms.<ID>.imu", f.name, f.default, str(f.metadata.get("help", ""))))
    return rows
