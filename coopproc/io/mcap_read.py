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
from coopproc.io.imu_csv import IMU_RATE_COLUMNS, checked_imu
from coopproc.io.mcap_json import fast_json_frame
from coopproc.io.mcap_ros2_read import NAVSAT_TO_Q, RosFields, ros_range_frame, ros_trajectory
from coopproc.io.mcap_scan import Channel, RawMcap, scan_mcap
from coopproc.io.odo_csv import checked_twist
from coopproc.io.ranges_csv import RangesRead, range_table_from_frame
from coopproc.io.session_toml import McapMapping
from coopproc.sensors import ImuData, OdometerData

__all__ = ["NAVSAT_TO_Q", "McapContent", "decode_mcap", "read_mcap_raw"]


@dataclass
class McapContent:
    """Everything a MCAP file holds, decoded."""

    nav: dict[str, RawTrajectory] = field(default_factory=dict)
    reference: dict[str, RawTrajectory] = field(default_factory=dict)
    ranges: RangesRead | None = None
    notes: list[str] = field(default_factory=list)
    #: Raw IMU samples (``[mcap] imu_topic``), checked like imu_<ID>.csv.
    imu_data: dict[str, ImuData] = field(default_factory=dict)
    #: Odometer samples (``[mcap] odometer_topic``; bags: ``[topics] odometer``).
    odometer: dict[str, OdometerData] = field(default_factory=dict)


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
    imu_re, odo_re = _topic_regex(mapping.imu_topic), _topic_regex(mapping.odometer_topic)
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
            m_imu, m_odo = imu_re.match(ch.topic), odo_re.match(ch.topic)
            if m_imu:
                out.imu_data[m_imu["id"]] = _imu_channel(ch, m_imu["id"], where)
                continue
            if m_odo:
                out.odometer[m_odo["id"]] = _odometer_channel(ch, m_odo["id"], where)
                if not (m_nav or m_ref):
                    continue
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


def _imu_channel(ch: Channel, pid: str, where: Locator) -> ImuData:
    """sensor_msgs/msg/Imu (ROS 2) or JSON ``time, gyro_x..z, accel_x..z``, checked."""
    at = Locator(f"{where.path} {ch.topic}", record=where.record)
    if ch.message_encoding == "json":
        frame = _json_frame(ch, where)
        missing = [c for c in IMU_RATE_COLUMNS if c not in frame.columns]
        if missing:
            raise at.error(f"no key '{missing[0]}'; expected time, {', '.join(IMU_RATE_COLUMNS)}")
        time = frame["time"].to_numpy(dtype=np.float64)
        values = frame[list(IMU_RATE_COLUMNS)].to_numpy(dtype=np.float64)
    else:
        f = RosFields(ch, where)
        time = f.times()
        values = np.column_stack(
            [f.get(f"angular_velocity.{a}") for a in "xyz"]
            + [f.get(f"linear_acceleration.{a}") for a in "xyz"]
        ).astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1) | ~np.isfinite(time))
    if bad.size:
        raise at.error("NaN or inf sample; expected finite numbers", int(bad[0]), bad.size)
    return checked_imu(pid, at, time, values)


def _odometer_channel(ch: Channel, pid: str, where: Locator) -> OdometerData:
    """nav_msgs/msg/Odometry twist (ROS 2) or JSON ``time, speed[, yaw_rate]``, checked."""
    at = Locator(f"{where.path} {ch.topic}", record=where.record)
    if ch.message_encoding == "json":
        frame = _json_frame(ch, where)
        if "speed" not in frame.columns:
            raise at.error("no key 'speed'; expected time, speed (m/s)[, yaw_rate (rad/s)]")
        yaw = frame["yaw_rate"].to_numpy(dtype=np.float64) if "yaw_rate" in frame else None
        time = frame["time"].to_numpy(dtype=np.float64)
        return checked_twist(pid, at, time, frame["speed"].to_numpy(dtype=np.float64), yaw)
    f = RosFields(ch, where)
    speed = np.asarray(f.get("twist.twist.linear.x"), dtype=np.float64)
    yaw_rate: np.ndarray | None = np.asarray(f.get("twist.twist.angular.z"), dtype=np.float64)
    if np.all(np.asarray(f.get("twist.covariance"), dtype=np.float64)[:, 35] < 0):
        yaw_rate = None  # coopproc's writer: variance -1 = no yaw rate
    return checked_twist(pid, at, f.times(), speed, yaw_rate)


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
