"""``coopproc info`` for a bag: its topics, types, counts and rates, and a ``[topics]``.

:func:`bag_report` returns the text (None when the session path neither is nor holds a
bag): one line about the bag, one row per topic with what the mapping makes of it
(session.toml ``[topics]`` when given, else the suggestion), then the suggested
``[topics]`` as TOML to paste into session.toml.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coopproc.errors import CoopprocError
from coopproc.io.rosbag_plan import topic_roles
from coopproc.io.rosbag_scan import BagInventory, find_bag, inventory, open_bag
from coopproc.io.rosbag_suggest import suggest
from coopproc.io.session_toml import read_session_toml
from coopproc.io.topics_toml import TopicsMapping

__all__ = ["bag_report", "format_bag"]


def bag_report(session: str | Path) -> str | None:
    """The bag part of ``coopproc info SESSION`` (None: no bag there)."""
    root = Path(session)
    topics: TopicsMapping | None = None
    if root.is_dir() and (root / "session.toml").is_file():
        topics = read_session_toml(root / "session.toml").topics
    bag = find_bag(root, topics.bag if topics is not None else None)
    if bag is None:
        return None
    with open_bag(bag) as reader:
        inv = inventory(reader, bag)
    return format_bag(inv, topics)


def format_bag(inv: BagInventory, topics: TopicsMapping | None = None) -> str:
    """The inventory table and the suggested ``[topics]`` (text)."""
    suggestion = suggest(inv.types, inv.fields)
    used = topics if topics is not None else suggestion.mapping
    label = "mapped" if topics is not None else "suggested"
    try:
        roles = topic_roles(inv.path, used, inv.types)
    except CoopprocError as err:
        roles = {}
        label += f" (mapping does not fit: {err})"
    n = sum(t.count for t in inv.topics)
    starts = [t.start_s for t in inv.topics if t.count]
    ends = [t.end_s for t in inv.topics if t.count]
    span = max(ends) - min(starts) if starts else 0.0
    rows = [("topic", "type", "messages", "rate_hz", label.split(" (")[0])]
    for t in inv.topics:
        rate = "-" if np.isnan(t.rate_hz) else f"{t.rate_hz:.2f}"
        rows.append((t.topic, t.msgtype, str(t.count), rate, roles.get(t.topic, "-")))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = [
        f"bag {inv.path}  ({inv.form}, {len(inv.topics)} topics, {n} messages, {span:.1f} s;"
        " rates from log times)",
    ]
    if "(" in label:
        lines.append(f"  {label}")
    for r in rows:
        cells = [r[0].ljust(widths[0]), r[1].ljust(widths[1])]
        cells += [r[2].rjust(widths[2]), r[3].rjust(widths[3]), r[4]]
        lines.append("  " + "  ".join(cells).rstrip())
    lines += [
        "",
        'suggested [topics] for session.toml (docs/formats.md "ROS bags"; check it):',
        "",
        *suggestion.lines,
    ]
    return "\n".join(lines)
