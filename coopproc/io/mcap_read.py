"""Read a session from one MCAP file: JSON channels and ROS 2 (CDR) channels.

Topics and range fields follow ``session.toml [mcap]`` (:class:`McapMapping`). A JSON
nav/reference message has the nav CSV columns as keys; a JSON range message
``{"from", "to", "range", ...}`` (extra keys carried through). ROS 2: nav as
``nav_msgs/msg/Odometry`` (pose.position = east, north, up; pose covariance diagonal ->
sigmas; orientation -> heading unless all zero; twist.linear -> ENU velocity unless all
zero), reference as ``sensor_msgs/msg/NavSatFix`` (geodetic; status -> Q) or Odometry,
ranges as any message with the mapped fields (dotted paths allowed). Time is the
message's own stamp (JSON ``time`` key, ROS ``header.stamp``) where it has one, else the
log time. An attachment named ``session.toml`` is returned for the session to use.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.io._common import (
    InputProblems,
    Locator,
    RawTrajectory,
    check_trajectory_times,
    one_line,
)
from coopproc.io.csv_traj import trajectory_from_frame
from coopproc.io.mcap_json import fast_json_frame
from coopproc.io.mcap_ros2_read import NAVSAT_TO_Q, ros_range_frame, ros_trajectory
from coopproc.io.mcap_scan import Channel, RawMcap, scan_mcap
from coopproc.io.ranges_csv import RangesRead, range_table_from_frame
from coopproc.io.session_toml import McapMapping

__all__ = ["NAVSAT_TO_Q", "McapContent", "decode_mcap", "read_mcap_raw"]


@dataclass
class McapContent:
    """Everything a MCAP file holds, decoded."""

    nav: dict[str, RawTrajectory] = field(default_factory=dict)
    reference: dict[str, RawTrajectory] = field(default_factory=dict)
    ranges: RangesRead | None = None
    notes: list[str] = field(default_factory=list)


def read_mcap_raw(path: str | Path) -> RawMcap:
    """Scan a MCAP file into per-channel message bytes (no decoding yet)."""
    return scan_mcap(Path(path))


def _topic_regex(template: str) -> re.Pattern[str]:
    parts = template.split("{id}")
    return re.compile("^" + "(?P<id>[A-Za-z0-9_-]+)".join(re.escape(p) for p in parts) + "$")


def decode_mcap(raw: RawMcap, mapping: McapMapping) -> McapContent:
    """Decode the nav, reference and range channels of a scanned MCAP file."""
    out = McapContent()
    nav_re, ref_re = _topic_regex(mapping.nav_topic), _topic_regex(mapping.reference_topic)
    problems: list[InputError] = []
    range_frames: list[pd.DataFrame] = []
    range_where: Locator | None = None
    for ch in raw.channels.values():
        if not len(ch):
            continue
        where = Locator(raw.path, record=_record_namer(ch.topic))
        try:
            if ch.topic == mapping.range_topic:
                range_frames.append(_range_frame(ch, mapping, where))
                range_where = where
                continue
            m_nav, m_ref = nav_re.match(ch.topic), ref_re.match(ch.topic)
            if m_nav or m_ref:
                pid = (m_nav or m_ref).group("id")  # type: ignore[union-attr]
                traj = _trajectory(ch, pid, where)
                target = out.nav if m_nav else out.reference
                if pid in target:
                    raise InputError(raw.path, f"two channels for {ch.topic}", record=ch.topic)
                target[pid] = traj
                continue
        except InputProblems as err:
            problems.extend(err.errors)
            continue
        except InputError as err:
            problems.append(err)
            continue
        out.notes.append(f"{raw.path}: topic {ch.topic} ({len(ch)} messages) not used")
    if range_frames and range_where is not None:
        frame = (
            pd.concat(range_frames, ignore_index=True) if len(range_frames) > 1 else range_frames[0]
        )
        try:
            out.ranges = range_table_from_frame(frame, range_where)
        except InputProblems as err:
            problems.extend(err.errors)
        except InputError as err:
            problems.append(err)
    if problems:
        raise InputProblems(problems)
    return out


def _record_namer(topic: str) -> Callable[[int], str]:
    return lambda i: f"{topic} message {i + 1}"


def _json_rows(ch: Channel, where: Locator) -> list[dict[str, Any]]:
    try:
        rows = json.loads(b"[" + b",".join(ch.data) + b"]")
    except (ValueError, UnicodeError, RecursionError):
        for i, data in enumerate(ch.data):
            try:
                json.loads(data)
            except (ValueError, UnicodeError, RecursionError) as err:
                raise where.error(
                    f"not valid JSON ({one_line(err)}); expected a JSON object", i
                ) from err
        raise where.error("not valid JSON; expected one JSON object per message") from None
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise where.error(f"found JSON {type(row).__name__}; expected an object", i)
    return rows


def _json_frame(ch: Channel, where: Locator) -> pd.DataFrame:
    frame = fast_json_frame(ch)
    if frame is None:
        frame = pd.DataFrame.from_records(_json_rows(ch, where))
    if "time" not in frame.columns:
        frame.insert(0, "time", np.asarray(ch.log_time_ns, dtype=np.int64) / 1e9)
    return frame


def _trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    raw = _read_trajectory(ch, pid, where)
    raw.source = f"{where.path} {ch.topic}"
    return raw


def _read_trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    if ch.message_encoding == "json":
        return trajectory_from_frame(_json_frame(ch, where), pid, where)
    raw = ros_trajectory(ch, pid, where)
    bad = ~np.isfinite(raw.position).all(axis=1) | ~np.isfinite(raw.time_s)
    if bad.any():
        idx = np.flatnonzero(bad)
        raise where.error("NaN or inf position; expected finite numbers", int(idx[0]), idx.size)
    return check_trajectory_times(raw, where)


def _range_frame(ch: Channel, mapping: McapMapping, where: Locator) -> pd.DataFrame:
    if ch.message_encoding == "json":
        frame = _json_frame(ch, where)
        renames = {mapping.from_field: "from", mapping.to_field: "to", mapping.range_field: "range"}
        renames[mapping.sigma_field] = "sigma"
        return frame.rename(columns={k: v for k, v in renames.items() if k != v})
    return ros_range_frame(ch, mapping, where)
