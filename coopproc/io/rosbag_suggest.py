"""A ``[topics]`` mapping suggested from a bag's topic names and types.

Topics of one role share a name but for one segment (the platform:
``/vrpn_client_node/turtlebot1/pose``, ``/vrpn_client_node/turtlebot2/pose`` ->
``/vrpn_client_node/{id}/pose``) or, for ``sensor_msgs/msg/Range``, two segments (the
pair: ``/uwb/tof/n_1/n_3/distance`` -> ``/uwb/tof/{from}/{to}/distance``). Roles by
type: ``nav_msgs/msg/Odometry`` -> nav; ``geometry_msgs/msg/PoseStamped`` (and
``PoseWithCovarianceStamped``), else ``sensor_msgs/msg/NavSatFix`` -> reference;
``sensor_msgs/msg/Imu`` -> imu. Range nodes are renamed to the platform whose name ends
in the same number (``n_1`` -> ``turtlebot1``); nodes with no such platform are dropped.
A range message of another type whose fields look like two ids and a range is mapped
field by field. The suggestion is printed as TOML by ``coopproc info`` and used as is
when session.toml has no ``[topics]`` (with a note).
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field

from coopproc.io.topics_toml import RangeTopics, TopicsMapping, topic_regex

__all__ = ["NAV_TYPES", "POSE_TYPES", "Suggestion", "suggest"]

ODOMETRY = "nav_msgs/msg/Odometry"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"
POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped")
#: Message types read as a trajectory (nav or reference).
NAV_TYPES = (ODOMETRY, *POSE_TYPES, NAVSATFIX)
RANGE = "sensor_msgs/msg/Range"
IMU = "sensor_msgs/msg/Imu"
_ID_WORDS = ("from", "to", "src", "dst", "source", "target", "initiator", "responder", "anchor")


@dataclass
class Suggestion:
    """The suggested mapping and the TOML lines (with comments) that say it."""

    mapping: TopicsMapping
    lines: list[str] = field(default_factory=list)

    @property
    def toml(self) -> str:
        return "\n".join(self.lines) + "\n"


def _segments(topic: str) -> list[str]:
    return topic.strip("/").split("/")


def _families(topics: Sequence[str], slots: int) -> list[tuple[str, list[tuple[str, ...]]]]:
    """Topics grouped by a template with ``slots`` varying segments, largest first.

    Returns (template with ``{0}``, ``{1}`` marks, the varying names of each topic).
    """
    best: list[tuple[str, list[tuple[str, ...]]]] = []
    by_count: dict[int, list[list[str]]] = defaultdict(list)
    for t in sorted(topics):
        by_count[len(_segments(t))].append(_segments(t))
    for n, group in sorted(by_count.items()):
        if n < slots:
            continue
        choices = _positions(n, slots)
        grouped_best: dict[tuple[str, ...], list[tuple[str, ...]]] | None = None
        for pos in choices:
            grouped: dict[tuple[str, ...], list[tuple[str, ...]]] = defaultdict(list)
            for segs in group:
                key = tuple(f"{{{pos.index(i)}}}" if i in pos else s for i, s in enumerate(segs))
                grouped[key].append(tuple(segs[i] for i in pos))
            if grouped_best is None or len(grouped) < len(grouped_best):
                grouped_best = grouped
        assert grouped_best is not None
        best += [("/" + "/".join(k), v) for k, v in grouped_best.items()]
    best.sort(key=lambda kv: (-len(kv[1]), kv[0]))
    return best


def _positions(n: int, slots: int) -> list[tuple[int, ...]]:
    if slots == 1:
        return [(i,) for i in range(n)]
    return [(i, j) for i in range(n) for j in range(i + 1, n)]


def _number(name: str) -> str | None:
    m = re.search(r"(\d+)$", name)
    return str(int(m.group(1))) if m else None


def _q(text: str) -> str:
    return json.dumps(text)


def _role(
    topics: Sequence[str], what: str, lines: list[str], types: dict[str, str]
) -> tuple[str | dict[str, str] | None, list[str]]:
    """A template (or a one-entry table) for topics of one role, and their platform names."""
    fams = _families(topics, 1)
    if not fams:
        return None, []
    template, names = fams[0]
    if len(names) == 1 and len(fams) == 1:
        segs = _segments(topics[0])
        pid = next((s for s in segs if _number(s) is not None), "A")
        pid = re.sub(r"[^A-Za-z0-9_-]", "_", pid)
        lines.append(f"{what} = {{ {pid} = {_q(topics[0])} }}  # {types[topics[0]]}")
        return {pid: topics[0]}, [pid]
    out = template.format("{id}")
    regex = topic_regex(out, ["id"])
    kinds = sorted({types[t] for t in topics if regex.match(t)})
    lines.append(f"{what} = {_q(out)}  # {', '.join(kinds)}: {len(names)} platforms")
    for other, more in fams[1:]:
        lines.append(f"# also {other.format('{id}')} ({len(more)} topics)")
    return out, [n[0] for n in names]


def _custom_range(types: dict[str, str], fields: dict[str, list[str]]) -> RangeTopics | None:
    for topic, msgtype in sorted(types.items()):
        if msgtype in (RANGE, *NAV_TYPES, IMU):
            continue
        names = fields.get(msgtype, [])
        leaf = {p: p.rsplit(".", 1)[-1].lower() for p in names}
        ranges = [p for p, n in leaf.items() if n in ("range", "distance", "dist")]
        ids = [p for p, n in leaf.items() if any(w in n for w in _ID_WORDS) and p not in ranges]
        if ranges and len(ids) >= 2:
            return RangeTopics(topic, from_field=ids[0], to_field=ids[1], range_field=ranges[0])
    return None


def suggest(types: dict[str, str], fields: dict[str, list[str]] | None = None) -> Suggestion:
    """The suggested ``[topics]`` for a bag with ``types`` (topic -> message type)."""
    fields = fields or {}
    lines = ["[topics]"]
    of = defaultdict(list)
    for topic, msgtype in sorted(types.items()):
        of[msgtype].append(topic)
    nav, nav_names = _role(of[ODOMETRY], "nav", lines, types)
    poses = [t for mt in POSE_TYPES for t in of[mt]] or of[NAVSATFIX]
    reference, ref_names = _role(sorted(poses), "reference", lines, types)
    imu, _ = _role(of[IMU], "imu", lines, types)
    ranges: RangeTopics | None = None
    nodes: list[str] = []
    fams = _families(of[RANGE], 2)
    if fams:
        template, pairs = fams[0]
        ranges = RangeTopics(template.format("{from}", "{to}"))
        nodes = sorted({n for p in pairs for n in p})
        lines.append(
            f"ranges = {_q(ranges.topic)}  # {RANGE}: {len(pairs)} topics, {len(nodes)} nodes"
        )
    else:
        ranges = _custom_range(types, fields)
        if ranges is not None:
            keys = {
                "topic": ranges.topic,
                "from_field": str(ranges.from_field),
                "to_field": str(ranges.to_field),
                "range_field": ranges.range_field,
            }
            inline = ", ".join(f"{k} = {_q(v)}" for k, v in keys.items())
            lines.append(f"ranges = {{ {inline} }}  # fields guessed from the message: check")
    platforms = sorted(set(nav_names) | set(ref_names))
    rename, drop = _match_nodes(nodes, platforms)
    if drop:
        lines.append(f"drop = {json.dumps(drop)}  # range nodes with no pose/odometry topic")
    if nav is None:
        lines.append(
            f"# no {ODOMETRY} topic: put nav_<ID>.csv files beside the bag (in the session"
            " directory), or map a pose as nav too:"
        )
        if isinstance(reference, str):
            lines.append(f"# nav = {_q(reference)}")
    if rename:
        lines += ["", "[topics.rename]  # range nodes -> platforms, by their number: check it"]
        lines += [f"{k} = {_q(v)}" for k, v in rename.items()]
    mapping = TopicsMapping(
        nav=nav, reference=reference, imu=imu, ranges=ranges, rename=rename, drop=tuple(drop)
    )
    return Suggestion(mapping, lines)


def _match_nodes(nodes: list[str], platforms: list[str]) -> tuple[dict[str, str], list[str]]:
    """Rename range nodes to the platform ending in the same number; drop the unmatched."""
    if not nodes or not platforms or set(nodes) <= set(platforms):
        return {}, []
    by_number: dict[str, list[str]] = defaultdict(list)
    for p in platforms:
        num = _number(p)
        if num is not None:
            by_number[num].append(p)
    rename: dict[str, str] = {}
    drop: list[str] = []
    for node in nodes:
        if node in platforms:
            continue
        num = _number(node)
        match = by_number.get(num, []) if num is not None else []
        if len(match) == 1:
            rename[node] = match[0]
        else:
            drop.append(node)
    if not rename:  # no node matched any platform: the numbers say nothing
        return {}, []
    return rename, drop
