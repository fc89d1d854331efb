"""session.toml ``[topics]``: which topics of a ROS bag hold what, for which platform.

::

    [topics]
    bag = "test3"                              # which bag of the directory (when several)
    nav = "/{id}/odom"                         # template: {id} = the platform
    reference = "/vrpn_client_node/{id}/pose"
    ranges = "/uwb/tof/{from}/{to}/distance"   # sensor_msgs/Range, the pair from the topic
    imu = "/{id}/imu"
    odometer = "/{id}/odom"                    # nav_msgs/Odometry twist: speed, yaw rate
    drop = ["n_8"]                             # names left out (ranges with them too)
    duplicates_s = 0.005                       # A->B and B->A copies of one range: one kept

    [topics.rename]                            # name in the topics -> platform id
    n_1 = "tb1"

``nav`` / ``reference`` / ``imu`` / ``odometer`` are a template holding ``{id}`` or a table
``<platform id> = "topic"``. ``ranges`` is a topic pattern holding ``{from}`` and
``{to}``, or a table ``topic, from_field, to_field, range_field, sigma_field`` for a
message that carries the ids itself. Checked here (keys, types, placeholders); matched
against a bag's topics in :mod:`coopproc.io.rosbag_read`.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from coopproc.configtools import check_keys, nearest
from coopproc.errors import ConfigError
from coopproc.io._common import ID_PATTERN

__all__ = [
    "RangeTopics",
    "TopicsMapping",
    "nearest_topic",
    "parse_topics",
    "topic_regex",
]

_KEYS = (
    "bag",
    "nav",
    "reference",
    "ranges",
    "imu",
    "odometer",
    "rename",
    "drop",
    "duplicates_s",
)
_RANGE_KEYS = ("topic", "from_field", "to_field", "range_field", "sigma_field")
_NAME = "[A-Za-z0-9_-]+"


@dataclass(frozen=True)
class RangeTopics:
    """Where the ranges are: a topic pattern, and the message fields to read."""

    topic: str
    #: Fields holding the two ends' ids; None when the pattern has {from} and {to}.
    from_field: str | None = None
    to_field: str | None = None
    range_field: str = "range"
    sigma_field: str | None = None

    @property
    def by_topic(self) -> bool:
        """The pair is taken from the topic name ({from}, {to})."""
        return self.from_field is None


@dataclass(frozen=True)
class TopicsMapping:
    """The ``[topics]`` table, checked."""

    #: Which bag of a session directory (file or folder name), when it holds several.
    bag: str | None = None
    #: role -> template with {id} (str) or {platform id: topic}.
    nav: str | Mapping[str, str] | None = None
    reference: str | Mapping[str, str] | None = None
    imu: str | Mapping[str, str] | None = None
    #: nav_msgs/msg/Odometry topics whose twist is the platform's odometer.
    odometer: str | Mapping[str, str] | None = None
    ranges: RangeTopics | None = None
    #: Name in the topics (or range message ids) -> platform id.
    rename: Mapping[str, str] = field(default_factory=dict)
    #: Names (as in the bag, or platform ids after renaming) left out.
    drop: tuple[str, ...] = ()
    #: A range equal to its pair's previous range (either direction) less than this many
    #: seconds before it is a copy of it, left out; 0 keeps every range.
    duplicates_s: float = 0.0
    #: Where it was read from, for messages (``session.toml [topics]``).
    where: str = "[topics]"

    def platform(self, name: str) -> str:
        """The platform id of a name found in a topic or a range message."""
        return self.rename.get(name, name)

    def dropped(self, name: str) -> bool:
        """Is ``name`` (a bag name) left out, by itself or by its platform id?"""
        return name in self.drop or self.platform(name) in self.drop


def topic_regex(template: str, names: Iterable[str]) -> re.Pattern[str]:
    """A regex for ``template`` whose placeholders ``{name}`` become named groups."""
    allowed = set(names)
    out, pos = "^", 0
    for m in re.finditer(r"\{([A-Za-z_]+)\}", template):
        if m.group(1) not in allowed:
            raise ValueError(m.group(1))
        out += re.escape(template[pos : m.start()]) + f"(?P<{m.group(1)}>{_NAME})"
        pos = m.end()
    return re.compile(out + re.escape(template[pos:]) + "$")


def nearest_topic(wanted: str, topics: Iterable[str]) -> str:
    """`` (nearest: '/x')`` for the bag topic closest to ``wanted`` (a topic or template).

    A topic is compared with its segments at the template's placeholder positions put
    back as placeholders, so ``/{id}/odometry`` is nearest to ``/A/odom``.
    """
    options = sorted(topics)
    if not options:
        return " (the bag has no topics)"
    marks = wanted.strip("/").split("/")
    holes = [i for i, s in enumerate(marks) if re.search(r"\{[A-Za-z_]+\}", s)]

    def score(topic: str) -> float:
        segs = topic.strip("/").split("/")
        if len(segs) == len(marks):
            segs = [marks[i] if i in holes else s for i, s in enumerate(segs)]
        return difflib.SequenceMatcher(None, wanted, "/" + "/".join(segs)).ratio()

    best = max(options, key=score)  # the first of equals in sorted order
    return f" (nearest: '{best}')"


def _placeholders(text: str) -> list[str]:
    return re.findall(r"\{([A-Za-z_]*)\}", text)


def _topic(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{where}: expected a topic name string, found {value!r}")
    if not value.startswith("/"):
        raise ConfigError(f"{where}: {value!r}; expected a topic name starting with '/'")
    return value


def _per_platform(value: Any, where: str) -> str | dict[str, str]:
    """A template with {id}, or a table platform id -> topic."""
    if isinstance(value, Mapping):
        out: dict[str, str] = {}
        for pid, topic in value.items():
            if not ID_PATTERN.match(pid):
                raise ConfigError(
                    f"{where}: platform id {pid!r}; expected letters, digits, '_' and '-'"
                )
            out[pid] = _topic(topic, f"{where} {pid}")
            if _placeholders(out[pid]):
                raise ConfigError(
                    f"{where} {pid}: {topic!r}; expected a topic without placeholders "
                    "in the table form"
                )
        return out
    template = _topic(value, where)
    marks = _placeholders(template)
    if marks != ["id"]:
        found = ", ".join("{" + m + "}" for m in marks) or "none"
        raise ConfigError(
            f"{where}: {template!r} has placeholders {found}; expected one {{id}} "
            '(e.g. "/{id}/odom"), or a table <platform id> = "topic"'
        )
    return template


def _ranges(value: Any, where: str) -> RangeTopics:
    table: Mapping[str, Any] = {"topic": value} if isinstance(value, str) else value
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where}: expected a topic pattern or a table, found {value!r}")
    check_keys(table, _RANGE_KEYS, where)
    if "topic" not in table:
        raise ConfigError(f"{where}: no 'topic'; expected topic = \"/uwb/range\"")
    topic = _topic(table["topic"], f"{where} topic")
    for key in _RANGE_KEYS[1:]:
        if key in table and (not isinstance(table[key], str) or not table[key].strip()):
            raise ConfigError(f"{where} {key}: expected a field name string, found {table[key]!r}")
    marks = sorted(_placeholders(topic))
    if marks == ["from", "to"]:
        given = [k for k in ("from_field", "to_field") if k in table]
        if given:
            raise ConfigError(
                f"{where} {given[0]}: the pattern {topic!r} names the pair already; "
                "expected either {from}/{to} in the topic or from_field/to_field"
            )
        return RangeTopics(
            topic,
            range_field=table.get("range_field", "range"),
            sigma_field=table.get("sigma_field"),
        )
    if marks:
        found = ", ".join("{" + m + "}" for m in marks)
        raise ConfigError(
            f"{where}: {topic!r} has placeholders {found}; expected both {{from}} and {{to}} "
            '(e.g. "/uwb/{from}/{to}/distance"), or none with from_field and to_field'
        )
    missing = [k for k in ("from_field", "to_field") if k not in table]
    if missing:
        raise ConfigError(
            f"{where}: {topic!r} has no {{from}}/{{to}} and no {missing[0]}; expected the "
            "message fields holding the two ids (from_field, to_field)"
        )
    return RangeTopics(
        topic,
        from_field=table["from_field"],
        to_field=table["to_field"],
        range_field=table.get("range_field", "range"),
        sigma_field=table.get("sigma_field"),
    )


def parse_topics(table: Any, where: str = "session.toml") -> TopicsMapping | None:
    """The checked ``[topics]`` table, or None when absent; ConfigError naming the key."""
    if table is None:
        return None
    where = f"{where} [topics]"
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where}: expected a table")
    check_keys(table, _KEYS, where)
    bag = table.get("bag")
    if bag is not None and (not isinstance(bag, str) or not bag or "/" in bag.strip("/")):
        raise ConfigError(f"{where} bag: {bag!r}; expected the name of a bag in the directory")
    roles = {
        key: _per_platform(table[key], f"{where} {key}")
        for key in ("nav", "reference", "imu", "odometer")
        if key in table
    }
    ranges = _ranges(table["ranges"], f"{where} ranges") if "ranges" in table else None
    rename = table.get("rename", {})
    if not isinstance(rename, Mapping):
        raise ConfigError(f'{where} rename: expected a table name = "platform id"')
    for name, pid in rename.items():
        if not isinstance(pid, str) or not ID_PATTERN.match(pid):
            raise ConfigError(
                f"{where} rename {name}: {pid!r}; expected a platform id (letters, digits, "
                "'_' and '-')"
            )
    drop = table.get("drop", [])
    if not isinstance(drop, list) or not all(isinstance(d, str) and d for d in drop):
        raise ConfigError(f'{where} drop: {drop!r}; expected a list of names, e.g. ["n_8"]')
    dup = table.get("duplicates_s", 0.0)
    if isinstance(dup, bool) or not isinstance(dup, int | float) or not 0 <= dup <= 1:
        raise ConfigError(
            f"{where} duplicates_s: {dup!r}; expected seconds, 0 <= duplicates_s <= 1 "
            "(e.g. 0.005; 0 keeps every range)"
        )
    return TopicsMapping(
        bag=bag.strip("/") if bag else None,
        nav=roles.get("nav"),
        reference=roles.get("reference"),
        imu=roles.get("imu"),
        odometer=roles.get("odometer"),
        ranges=ranges,
        rename=dict(rename),
        drop=tuple(drop),
        duplicates_s=float(dup),
        where=where,
    )


def unused_names(mapping: TopicsMapping, seen: set[str]) -> ConfigError | None:
    """An error for a rename or drop entry that names nothing the bag's topics hold."""
    platforms = {mapping.platform(s) for s in seen}
    for key, names in (("rename", list(mapping.rename)), ("drop", list(mapping.drop))):
        for name in names:
            if name in seen or (key == "drop" and name in platforms):
                continue
            hint = nearest(name, seen).replace("valid keys", "names")
            return ConfigError(
                f"{mapping.where} {key}: '{name}' is not a name in the mapped topics{hint}"
            )
    return None
