"""Which topics of a bag give what: ``[topics]`` matched against the bag's topic names.

Templates and patterns (:mod:`coopproc.io.topics_toml`) are matched against every topic:
the names they capture are renamed and dropped as ``[topics]`` says, each topic's type is
checked against its role, and a mapped topic the bag does not have is one ConfigError
naming the nearest topic. The result (:class:`Plan`) says which topic gives each
platform's nav, reference and IMU, and which topics give ranges between which names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from coopproc.errors import ConfigError, InputError
from coopproc.io.rosbag_suggest import IMU, NAV_TYPES, ODOMETRY, RANGE
from coopproc.io.topics_toml import TopicsMapping, nearest_topic, topic_regex, unused_names

__all__ = ["Plan", "plan_topics", "topic_roles"]


@dataclass
class Plan:
    """Which topic gives what: role -> {platform: topic}; range topics -> (from, to)."""

    roles: dict[str, dict[str, str]] = field(default_factory=dict)
    ranges: dict[str, tuple[str, str] | None] = field(default_factory=dict)
    seen: set[str] = field(default_factory=set)
    #: Topics of dropped names.
    dropped: set[str] = field(default_factory=set)
    notes: list[str] = field(default_factory=list)

    @property
    def topics(self) -> set[str]:
        return {t for r in self.roles.values() for t in r.values()} | set(self.ranges)


def topic_roles(path: Path, topics: TopicsMapping, types: dict[str, str]) -> dict[str, str]:
    """What ``topics`` makes of each topic of a bag (``coopproc info``); raises like a read."""
    plan = plan_topics(path, topics, types)
    out = {t: f"{role} {pid}" for role, e in plan.roles.items() for pid, t in e.items()}
    for topic, pair in plan.ranges.items():
        ends = "ids in the message" if pair is None else "-".join(map(topics.platform, pair))
        out[topic] = f"ranges {ends}"
        if pair is not None and any(topics.dropped(n) for n in pair):
            out[topic] = f"dropped ({'-'.join(pair)})"
    out.update({t: "dropped" for t in plan.dropped})
    return out


def plan_topics(path: Path, topics: TopicsMapping, types: dict[str, str]) -> Plan:
    plan = Plan()
    where = topics.where
    for role in ("nav", "reference", "imu", "odometer"):
        spec = getattr(topics, role)
        if spec is None:
            continue
        allowed = {"imu": (IMU,), "odometer": (ODOMETRY,)}.get(role, NAV_TYPES)
        entries: dict[str, str] = {}
        if isinstance(spec, str):
            regex = topic_regex(spec, ["id"])
            for topic in sorted(types):
                m = regex.match(topic)
                if not m:
                    continue
                plan.seen.add(m["id"])
                if topics.dropped(m["id"]):
                    plan.dropped.add(topic)
                    continue
                pid = topics.platform(m["id"])
                if pid in entries:
                    raise ConfigError(
                        f"{where} {role}: {entries[pid]} and {topic} are both platform {pid}; "
                        "expected one topic per platform (check [topics.rename])"
                    )
                entries[pid] = topic
            if not entries and not any(regex.match(t) for t in types):
                raise ConfigError(
                    f"{where} {role}: '{spec}' matches no topic of {path}"
                    f"{nearest_topic(spec, types)}"
                )
        else:
            for pid, topic in spec.items():
                if topic not in types:
                    raise ConfigError(
                        f"{where} {role} {pid}: no topic '{topic}' in {path}"
                        f"{nearest_topic(topic, types)}"
                    )
                entries[pid] = topic
        for topic in entries.values():
            if types[topic] not in allowed:
                raise InputError(
                    path,
                    f"{topic} is {types[topic]}; expected {' or '.join(allowed)} for "
                    f"[topics] {role}",
                )
        plan.roles[role] = entries
    if topics.ranges is not None:
        _plan_ranges(path, topics, types, plan)
    if topics.nav is None:
        plan.notes.append(
            f"{path}: no [topics] nav: navigation must come from nav_<ID>.csv beside the bag"
        )
    if plan.dropped:
        plan.notes.append(
            f"{path}: {len(plan.dropped)} topic(s) of dropped names left out ([topics] drop): "
            + ", ".join(sorted(plan.dropped)[:3])
            + (", ..." if len(plan.dropped) > 3 else "")
        )
    unmapped = sorted(set(types) - plan.topics - plan.dropped)
    if unmapped:
        shown = ", ".join(unmapped[:5]) + (", ..." if len(unmapped) > 5 else "")
        plan.notes.append(f"{path}: {len(unmapped)} topic(s) not mapped, not used: {shown}")
    if topics.ranges is None or topics.ranges.by_topic:
        err = unused_names(topics, plan.seen)
        if err is not None:
            raise err
    return plan


def _plan_ranges(path: Path, topics: TopicsMapping, types: dict[str, str], plan: Plan) -> None:
    spec = topics.ranges
    assert spec is not None
    where = f"{topics.where} ranges"
    if not spec.by_topic:
        if spec.topic not in types:
            raise ConfigError(
                f"{where}: no topic '{spec.topic}' in {path}{nearest_topic(spec.topic, types)}"
            )
        plan.ranges[spec.topic] = None
        return
    regex = topic_regex(spec.topic, ["from", "to"])
    matched = [t for t in sorted(types) if regex.match(t)]
    if not matched:
        raise ConfigError(
            f"{where}: '{spec.topic}' matches no topic of {path}{nearest_topic(spec.topic, types)}"
        )
    for topic in matched:
        m = regex.match(topic)
        assert m is not None
        plan.seen.update((m["from"], m["to"]))
        plan.ranges[topic] = (m["from"], m["to"])
    others = [t for t, mt in sorted(types.items()) if mt == RANGE and t not in plan.ranges]
    if others:
        plan.notes.append(
            f"{path}: {len(others)} {RANGE} topic(s) do not match [topics] ranges "
            f"'{spec.topic}', not used: {', '.join(others[:3])}{', ...' if len(others) > 3 else ''}"
        )
