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
import math
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
from coopproc.io.mcap_scan import Channel, RawMcap, scan_mcap
from coopproc.io.ranges_csv import RangesRead, range_table_from_frame
from coopproc.io.session_toml import McapMapping

__all__ = ["NAVSAT_TO_Q", "McapContent", "decode_mcap", "read_mcap_raw"]

#: sensor_msgs/NavSatStatus status -> RTKLIB-style Q (2 GBAS/RTK -> 1 fix, 1 SBAS -> 3,
#: 0 plain fix -> 5 single, -1 no fix -> 0).
NAVSAT_TO_Q = {2: 1, 1: 3, 0: 5, -1: 0}


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
        frame.insert(0, "time", np.asarray(ch.log_time_ns, dtype=np.float64) * 1e-9)
    return frame


def _decoded(ch: Channel, where: Locator) -> list[Any]:
    if ch.decoder is None:
        raise where.error(
            f"message encoding '{ch.message_encoding}' with schema '{ch.schema_name}' "
            "not supported; expected json or ROS 2 cdr with a ros2msg schema"
        )
    out = []
    for i, data in enumerate(ch.data):
        try:
            out.append(ch.decoder(data))
        except Exception as err:  # the CDR decoder raises anything on bad bytes
            raise where.error(
                f"cannot decode {ch.schema_name} ({type(err).__name__}); corrupt message", i
            ) from err
    return out


def _stamp_times(msgs: list[Any], ch: Channel) -> np.ndarray:
    log = np.asarray(ch.log_time_ns, dtype=np.float64) * 1e-9
    t = log.copy()
    for i, m in enumerate(msgs):
        header = getattr(m, "header", None)
        if header is not None:
            stamp = header.stamp
            if stamp.sec or stamp.nanosec:
                t[i] = stamp.sec + stamp.nanosec * 1e-9
    return t


def _trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    raw = _read_trajectory(ch, pid, where)
    raw.source = f"{where.path} {ch.topic}"
    return raw


def _read_trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    if ch.message_encoding == "json":
        return trajectory_from_frame(_json_frame(ch, where), pid, where)
    msgs = _decoded(ch, where)
    time_s = _stamp_times(msgs, ch)
    name = ch.schema_name.replace("/msg/", "/")
    if name == "nav_msgs/Odometry":
        raw = _odometry(msgs, pid, time_s, where)
    elif name == "sensor_msgs/NavSatFix":
        raw = _navsatfix(msgs, pid, time_s, where)
    else:
        raise where.error(
            f"schema {ch.schema_name}; expected nav_msgs/msg/Odometry or sensor_msgs/msg/NavSatFix"
        )
    bad = ~np.isfinite(raw.position).all(axis=1) | ~np.isfinite(raw.time_s)
    if bad.any():
        idx = np.flatnonzero(bad)
        raise where.error("NaN or inf position; expected finite numbers", int(idx[0]), idx.size)
    return check_trajectory_times(raw, where)


def _odometry(msgs: list[Any], pid: str, time_s: np.ndarray, where: Locator) -> RawTrajectory:
    n = len(msgs)
    pos, cov, quat, vel = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4)), np.empty((n, 3))
    for i, m in enumerate(msgs):
        p, o = m.pose.pose.position, m.pose.pose.orientation
        c, v = m.pose.covariance, m.twist.twist.linear
        pos[i] = (p.x, p.y, p.z)
        cov[i] = (c[0], c[7], c[14])
        quat[i] = (o.x, o.y, o.z, o.w)
        vel[i] = (v.x, v.y, v.z)
    heading = None
    if np.any(quat != 0):
        x, y, z, w = quat.T
        yaw = np.degrees(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
        heading = np.mod(90.0 - yaw, 360.0)
    return RawTrajectory(
        platform=pid,
        time_s=time_s,
        position=pos,
        form="enu",
        source=where.path,
        sigma_enu_m=np.sqrt(np.clip(cov, 0, None)) if np.any(cov != 0) else None,
        vel_enu_mps=vel if np.any(vel != 0) else None,
        heading_deg=heading,
    )


def _navsatfix(msgs: list[Any], pid: str, time_s: np.ndarray, where: Locator) -> RawTrajectory:
    n = len(msgs)
    llh, cov = np.empty((n, 3)), np.empty((n, 3))
    q = np.empty(n, dtype=np.int64)
    for i, m in enumerate(msgs):
        llh[i] = (m.latitude, m.longitude, m.altitude)
        c = m.position_covariance
        cov[i] = (c[0], c[4], c[8])
        q[i] = NAVSAT_TO_Q.get(int(m.status.status), 0)
    return RawTrajectory(
        platform=pid,
        time_s=time_s,
        position=llh,
        form="llh",
        source=where.path,
        sigma_enu_m=np.sqrt(np.clip(cov, 0, None)) if np.any(cov != 0) else None,
        quality=q,
    )


def _field(msg: Any, path: str) -> Any:
    value = msg
    for part in path.split("."):
        value = getattr(value, part)
    return value


def _range_frame(ch: Channel, mapping: McapMapping, where: Locator) -> pd.DataFrame:
    if ch.message_encoding == "json":
        frame = _json_frame(ch, where)
        renames = {mapping.from_field: "from", mapping.to_field: "to", mapping.range_field: "range"}
        renames[mapping.sigma_field] = "sigma"
        return frame.rename(columns={k: v for k, v in renames.items() if k != v})
    msgs = _decoded(ch, where)
    time_s = _stamp_times(msgs, ch)
    cols: dict[str, list[Any]] = {"from": [], "to": [], "range": [], "sigma": []}
    paths = {
        "from": mapping.from_field,
        "to": mapping.to_field,
        "range": mapping.range_field,
        "sigma": mapping.sigma_field,
    }
    for name, fpath in paths.items():
        try:
            cols[name] = [_field(m, fpath) for m in msgs]
        except AttributeError as err:
            if name == "sigma":
                cols[name] = [math.nan] * len(msgs)
                continue
            raise where.error(
                f"{ch.schema_name} has no field '{fpath}' (session.toml [mcap] "
                f"{name}_field); expected the message field holding the {name}",
                0,
            ) from err
    frame = pd.DataFrame(
        {
            "time": time_s,
            "from": [str(v) for v in cols["from"]],
            "to": [str(v) for v in cols["to"]],
            "range": cols["range"],
            "sigma": cols["sigma"],
        }
    )
    return frame
