"""ROS bags: find them, open them (rosbags ``AnyReader``), list their topics, read channels.

A bag is a ROS 1 ``*.bag`` file or a ROS 2 bag folder (``metadata.yaml`` beside its
``.db3`` / ``.mcap`` storage files). ``rosbags.highlevel.AnyReader`` reads all three
forms and deserializes with the definitions the bag stores, else with the standard ROS 2
types of Humble (``metadata.yaml`` version <= 6) or Jazzy (later). The messages of a
topic become one :class:`~coopproc.io.mcap_scan.Channel` (all message bytes in one
buffer): ROS 2 CDR channels carry their ``ros2msg`` definition, so
:mod:`coopproc.io.cdr_fast` reads a field of all messages at once; ROS 1 messages are
decoded one by one. Any failure of the library on a truncated or corrupt bag is one
InputError naming the bag.
"""

from __future__ import annotations

import contextlib
import functools
import re
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from coopproc.configtools import nearest
from coopproc.errors import ConfigError, CoopprocError, InputError
from coopproc.io._common import one_line
from coopproc.io.mcap_scan import Channel

if TYPE_CHECKING:  # pragma: no cover
    from rosbags.highlevel import AnyReader
    from rosbags.typesys.store import Typestore

__all__ = [
    "BagInventory",
    "TopicInfo",
    "bag_files",
    "find_bag",
    "inventory",
    "is_bag",
    "open_bag",
    "read_channels",
]

_EXPECTED = "expected a ROS 1 .bag file or a ROS 2 bag folder (metadata.yaml + .db3/.mcap)"


def is_bag(path: Path) -> bool:
    """A ROS 1 ``.bag`` file or a ROS 2 bag folder (holding ``metadata.yaml``)."""
    if path.is_file():
        return path.name.lower().endswith(".bag")
    return path.is_dir() and (path / "metadata.yaml").is_file()


def find_bag(root: Path, name: str | None = None) -> Path | None:
    """The bag a session path is or holds (None: no bag).

    ``root`` itself (a ``.bag`` file or a ROS 2 bag folder), else the one bag in the
    directory ``root``; ``name`` (``[topics] bag``) picks one of several.
    """
    if is_bag(root):
        return root
    if not root.is_dir():
        return None
    found = sorted(p for p in root.iterdir() if is_bag(p))
    if name is not None:
        for p in found:
            if name in (p.name, p.stem):
                return p
        hint = " (no bag there)"
        if found:
            hint = nearest(name, [p.name for p in found]).replace("valid keys", "bags")
        raise ConfigError(f"session.toml [topics] bag: '{name}' is not a bag in {root}{hint}")
    if len(found) > 1:
        names = ", ".join(p.name for p in found)
        raise InputError(root, f"several bags ({names}); expected one, or [topics] bag")
    return found[0] if found else None


def bag_files(path: Path) -> list[Path]:
    """The files of a bag (for run.json hashes): the .bag, or metadata.yaml and storage."""
    if path.is_file():
        return [path]
    return sorted(p for p in path.iterdir() if p.is_file() and not p.name.startswith("."))


@functools.lru_cache(maxsize=2)
def _typestore(old: bool) -> Typestore:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(
        Stores.ROS2_HUMBLE if old else getattr(Stores, "ROS2_JAZZY", Stores.LATEST)
    )


def _old_ros2(path: Path) -> bool:
    """A ROS 2 bag of Humble or before (metadata version <= 6: sensor_msgs/Range has no
    ``variance`` yet); its types are taken from Humble when the bag stores none."""
    try:
        text = (path / "metadata.yaml").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return True
    m = re.search(r"^\s*version:\s*(\d+)", text, re.M)
    return m is None or int(m.group(1)) <= 6


def _fail(path: Path, err: BaseException, doing: str) -> InputError:
    found = f"{type(err).__name__}: {one_line(err, 200)}"
    return InputError(path, f"cannot {doing} ({found}); {_EXPECTED}")


@contextmanager
def open_bag(path: Path) -> Iterator[AnyReader]:
    """An open ``AnyReader`` on ``path``; library errors become one InputError."""
    from rosbags.highlevel import AnyReader

    if not path.exists():
        raise InputError(path, f"no such file or directory; {_EXPECTED}")
    old = path.is_file() or _old_ros2(path)
    reader = AnyReader([path], default_typestore=_typestore(old))
    try:
        reader.open()
    except Exception as err:  # rosbags, sqlite, yaml, lz4... raise anything on bad bytes
        raise _fail(path, err, "open the bag") from err
    try:
        yield reader
    finally:
        with contextlib.suppress(Exception):  # closing a half-read bag
            reader.close()


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag: type, message count, first and last log time (s)."""

    topic: str
    msgtype: str
    count: int
    start_s: float
    end_s: float

    @property
    def rate_hz(self) -> float:
        """Messages per second over the topic's own span (NaN for fewer than 2)."""
        span = self.end_s - self.start_s
        return (self.count - 1) / span if self.count > 1 and span > 0 else float("nan")


@dataclass
class BagInventory:
    """What a bag holds: its form and topics (sorted by name), with field names per type."""

    path: Path
    form: str  # "ROS 1", "ROS 2 sqlite3", "ROS 2 mcap"
    topics: list[TopicInfo] = field(default_factory=list)
    #: msgtype -> its field paths (dotted, nested messages expanded), for suggestions.
    fields: dict[str, list[str]] = field(default_factory=dict)

    @property
    def types(self) -> dict[str, str]:
        return {t.topic: t.msgtype for t in self.topics}


def _form(reader: AnyReader, path: Path) -> str:
    if not reader.is2:
        return "ROS 1"
    suffixes = {p.suffix for p in bag_files(path)}
    return "ROS 2 mcap" if ".mcap" in suffixes else "ROS 2 sqlite3"


def _field_paths(store: Any, msgtype: str, prefix: str = "", depth: int = 0) -> list[str]:
    """Dotted paths of the fields of ``msgtype`` (nested messages expanded, 4 levels)."""
    try:
        _, fields = store.fielddefs[msgtype]
    except KeyError:
        return []
    out: list[str] = []
    for name, desc in fields:
        kind, arg = desc[0], desc[1]
        if getattr(kind, "name", str(kind)) == "NAME" and depth < 4:
            out += _field_paths(store, arg, f"{prefix}{name}.", depth + 1)
        else:
            out.append(prefix + name)
    return out


def inventory(reader: AnyReader, path: Path, *, times: bool = True) -> BagInventory:
    """Every topic's type, count and log-time span (``times``: reads every message's log
    time, decodes nothing; else counts from the bag's index and no spans)."""
    stamps: dict[str, list[int]] = {}
    types: dict[str, str] = {}
    counts: dict[str, int] = {}
    for conn in reader.connections:
        types.setdefault(conn.topic, conn.msgtype)
        stamps.setdefault(conn.topic, [])
        counts[conn.topic] = counts.get(conn.topic, 0) + conn.msgcount
    try:
        for conn, t_ns, _ in reader.messages() if times else ():
            stamps[conn.topic].append(t_ns)
    except Exception as err:
        raise _fail(path, err, "read the bag's messages") from err
    out = BagInventory(path, _form(reader, path))
    for topic in sorted(types):
        t = np.asarray(stamps[topic], dtype=np.float64) * 1e-9
        lo, hi = (float(t.min()), float(t.max())) if t.size else (float("nan"), float("nan"))
        count = int(t.size) if times else counts[topic]
        out.topics.append(TopicInfo(topic, types[topic], count, lo, hi))
    for msgtype in sorted(set(types.values())):
        out.fields[msgtype] = _field_paths(reader.typestore, msgtype)
    return out


def _decoder(reader: AnyReader, msgtype: str) -> Callable[[bytes], Any]:
    store = reader.typestore
    if reader.is2:
        return lambda data: store.deserialize_cdr(data, msgtype)
    return lambda data: store.deserialize_ros1(data, msgtype)


def read_channels(reader: AnyReader, path: Path, topics: Collection[str]) -> dict[str, Channel]:
    """The messages of ``topics`` as one Channel each (file order; log times kept)."""
    wanted = [c for c in reader.connections if c.topic in set(topics)]
    data: dict[str, list[bytes]] = {c.topic: [] for c in wanted}
    log_ns: dict[str, list[int]] = {c.topic: [] for c in wanted}
    msgtypes: dict[str, str] = {}
    for conn in wanted:
        first = msgtypes.setdefault(conn.topic, conn.msgtype)
        if first != conn.msgtype:
            raise InputError(
                path, f"topic {conn.topic} has two types ({first}, {conn.msgtype}); expected one"
            )
    if not wanted:
        return {}
    try:
        for conn, t_ns, raw in reader.messages(connections=wanted):
            data[conn.topic].append(bytes(raw))
            log_ns[conn.topic].append(t_ns)
    except CoopprocError:
        raise
    except Exception as err:
        raise _fail(path, err, "read the bag's messages") from err
    out: dict[str, Channel] = {}
    for topic, chunks in data.items():
        msgtype = msgtypes[topic]
        lengths = np.fromiter((len(c) for c in chunks), dtype=np.int64, count=len(chunks))
        ends = np.cumsum(lengths)
        schema = b""
        if reader.is2:
            try:
                schema = reader.typestore.generate_msgdef(msgtype, ros_version=2)[0].encode()
            except Exception:  # no definition: decoded message by message (or an error then)
                schema = b""
        out[topic] = Channel(
            topic=topic,
            message_encoding="cdr" if reader.is2 else "ros1",
            schema_name=msgtype,
            schema_encoding="ros2msg" if schema else "",
            schema_data=schema,
            decoder=_decoder(reader, msgtype),
            buffer=b"".join(chunks),
            starts=ends - lengths,
            ends=ends,
            log_time_ns=np.asarray(log_ns[topic], dtype=np.uint64),
        )
    return out
