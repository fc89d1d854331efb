"""Read a session's navigation, reference, ranges and IMU from a ROS bag (``[topics]``).

The bag gives the same raw tables as the CSV and MCAP readers (``RawTrajectory`` per
platform and role, one range table), which the session loader assembles and checks like
any other input. Decisions (docs/formats.md "ROS bags"):

- time: the header stamp where it is non-zero, else the log time (nanoseconds -> s);
- ``nav_msgs/msg/Odometry`` and ``sensor_msgs/msg/NavSatFix`` as in MCAP sessions;
  ``geometry_msgs/msg/PoseStamped`` / ``PoseWithCovarianceStamped``: ``position`` = east,
  north, up in the session frame, orientation -> heading (REP 103: body x forward; an
  all-zero quaternion: none), the covariance diagonal of the latter -> sigmas;
- ``sensor_msgs/msg/Range``: ``range`` in metres, ``sqrt(variance)`` as sigma where the
  message has a positive ``variance`` (ROS 2 Iron on); a non-finite range (REP 117: no
  detection) is no measurement and is left out, with a note;
- names from topics and range messages are renamed by ``[topics.rename]``; names in
  ``[topics] drop`` are left out with every range they take part in;
- ``sensor_msgs/msg/Imu``: read into :class:`ImuSamples` (``read_bag``), checked like
  ``imu_<ID>.csv`` and attached to the session (``Session.imu``) by the session loader;
- ``[topics] odometer``: the twist of ``nav_msgs/msg/Odometry`` (``linear.x`` forward speed,
  ``angular.z`` yaw rate) -> :class:`~coopproc.sensors.OdometerData` (``Session.odometer``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError, InputError
from coopproc.io._common import InputProblems, Locator, RawTrajectory, check_trajectory_times
from coopproc.io.mcap_read import McapContent
from coopproc.io.mcap_ros2_read import RosFields, ros_trajectory
from coopproc.io.mcap_scan import Channel
from coopproc.io.odo_csv import checked_twist
from coopproc.io.ranges_csv import RangesRead, range_table_from_frame
from coopproc.io.rosbag_plan import Plan, plan_topics
from coopproc.io.rosbag_scan import find_bag, inventory, open_bag, read_channels
from coopproc.io.rosbag_suggest import POSE_TYPES, RANGE, suggest
from coopproc.io.topics_toml import (
    RangeTopics,
    TopicsMapping,
    unused_names,
)
from coopproc.model import FloatArray, SensorFile
from coopproc.sensors import OdometerData

__all__ = ["BagContent", "ImuSamples", "read_bag", "session_bag"]


@dataclass
class ImuSamples:
    """The samples of one ``sensor_msgs/msg/Imu`` topic (body frame, REP 103)."""

    platform: str
    topic: str
    time_s: FloatArray
    #: (n, 3) angular velocity, rad/s.
    gyro_radps: FloatArray
    #: (n, 3) specific force, m/s^2.
    accel_mps2: FloatArray


@dataclass
class BagContent(McapContent):
    """What a bag gives a session: McapContent plus the IMU samples (listed, not used)."""

    imu: dict[str, ImuSamples] = field(default_factory=dict)
    sensors: list[SensorFile] = field(default_factory=list)
    mapping: TopicsMapping | None = None


def session_bag(root: Path, topics: TopicsMapping | None) -> tuple[Path, BagContent] | None:
    """The bag a session path is or holds, read with ``topics`` (None: no bag there)."""
    bag = find_bag(root, topics.bag if topics is not None else None)
    if bag is None:
        if topics is not None:
            raise ConfigError(
                f"{topics.where}: given, but {root} holds no ROS bag; expected a .bag file or "
                "a ROS 2 bag folder (metadata.yaml + .db3/.mcap) beside session.toml"
            )
        return None
    return bag, read_bag(bag, topics)


def read_bag(path: str | Path, topics: TopicsMapping | None = None) -> BagContent:
    """Read the mapped topics of a bag (``topics`` None: the suggested mapping, noted)."""
    path = Path(path)
    with open_bag(path) as reader:
        inv = inventory(reader, path, times=False)
        notes = []
        if topics is None:
            topics = suggest(inv.types, inv.fields).mapping
            notes.append(
                f"{path}: no [topics] in session.toml: the suggested mapping used "
                "(coopproc info prints it)"
            )
        plan = plan_topics(path, topics, inv.types)
        channels = read_channels(reader, path, plan.topics)
    out = BagContent(mapping=topics, notes=notes + plan.notes)
    problems: list[InputError] = []
    for role, entries in sorted(plan.roles.items()):
        for pid, topic in sorted(entries.items()):
            where = Locator(str(path), record=_namer(topic))
            try:
                if role == "odometer":
                    out.odometer[pid] = _odometer(channels[topic], pid, where, path)
                    out.sensors.append(SensorFile("odo", path, pid))
                elif role == "imu":
                    out.imu[pid] = _imu(channels[topic], pid, where)
                    out.sensors.append(SensorFile("imu", path, pid))
                else:
                    target = out.nav if role == "nav" else out.reference
                    target[pid] = _trajectory(channels[topic], pid, where, f"{path} {topic}")
            except InputProblems as err:
                problems.extend(err.errors)
            except InputError as err:
                problems.append(err)
    if plan.ranges:
        try:
            out.ranges = _ranges(path, topics, plan, channels, out.notes)
        except InputProblems as err:
            problems.extend(err.errors)
        except InputError as err:
            problems.append(err)
    if problems:
        raise InputProblems(problems)
    return out


def _namer(topic: str) -> Callable[[int], str]:
    return lambda i: f"{topic} message {i + 1}"


def _trajectory(ch: Channel, pid: str, where: Locator, source: str) -> RawTrajectory:
    if ch.schema_name in POSE_TYPES:
        raw = _pose_trajectory(ch, pid, where)
    else:
        raw = ros_trajectory(ch, pid, where)
    bad = ~np.isfinite(raw.position).all(axis=1) | ~np.isfinite(raw.time_s)
    if bad.any():
        idx = np.flatnonzero(bad)
        raise where.error("NaN or inf position; expected finite numbers", int(idx[0]), idx.size)
    raw.source = source
    return check_trajectory_times(raw, Locator(source, record=where.record))


def _pose_trajectory(ch: Channel, pid: str, where: Locator) -> RawTrajectory:
    f = RosFields(ch, where)
    pose = "pose.pose." if ch.schema_name.endswith("WithCovarianceStamped") else "pose."
    pos = np.column_stack([f.get(pose + "position." + a) for a in "xyz"]).astype(np.float64)
    quat = np.column_stack([f.get(pose + "orientation." + a) for a in "xyzw"]).astype(np.float64)
    heading = None
    if np.any(quat != 0):
        x, y, z, w = quat.T
        yaw = np.degrees(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
        heading = np.mod(90.0 - yaw, 360.0)
    sigma = None
    if pose == "pose.pose.":
        cov = np.asarray(f.get("pose.covariance"), dtype=np.float64)[:, [0, 7, 14]]
        sigma = np.sqrt(np.clip(cov, 0, None)) if np.any(cov != 0) else None
    return RawTrajectory(
        platform=pid,
        time_s=f.times(),
        position=pos,
        form="enu",
        source=where.path,
        sigma_enu_m=sigma,
        heading_deg=heading,
    )


def _imu(ch: Channel, pid: str, where: Locator) -> ImuSamples:
    f = RosFields(ch, where)
    gyro = np.column_stack([f.get(f"angular_velocity.{a}") for a in "xyz"]).astype(np.float64)
    acc = np.column_stack([f.get(f"linear_acceleration.{a}") for a in "xyz"]).astype(np.float64)
    return ImuSamples(pid, ch.topic, f.times(), gyro, acc)


def _odometer(ch: Channel, pid: str, where: Locator, path: Path) -> OdometerData:
    f = RosFields(ch, where)
    speed = np.asarray(f.get("twist.twist.linear.x"), dtype=np.float64)
    yaw_rate = np.asarray(f.get("twist.twist.angular.z"), dtype=np.float64)
    at = Locator(f"{path} {ch.topic}", record=where.record)
    return checked_twist(pid, at, f.times(), speed, yaw_rate)


def _copies(frame: pd.DataFrame, window_s: float) -> np.ndarray:
    """Rows equal to the previous range of their pair (either direction) within the window."""
    src, dst = frame["from"].to_numpy(dtype=object), frame["to"].to_numpy(dtype=object)
    pair = np.where(src < dst, src + "\x00" + dst, dst + "\x00" + src)
    t = frame["time"].to_numpy(dtype=np.float64)
    r = frame["range"].to_numpy(dtype=np.float64)
    order = np.lexsort((t, pair))  # by pair, then time (stable)
    p, ts, rs = pair[order], t[order], r[order]
    same = np.zeros(len(frame), dtype=bool)
    same[1:] = (p[1:] == p[:-1]) & (ts[1:] - ts[:-1] < window_s) & (rs[1:] == rs[:-1])
    out = np.zeros(len(frame), dtype=bool)
    out[order] = same
    return out


def _id_fields(spec: RangeTopics) -> list[tuple[str | None, str]]:
    return [(spec.from_field, "from_field"), (spec.to_field, "to_field")]


def _field(f: RosFields, name: str, key: str, ch: Channel, where: Locator) -> np.ndarray:
    if not f.has(name):
        raise where.error(
            f"{ch.schema_name} on {ch.topic} has no field '{name}' ([topics] ranges {key}); "
            f"expected the message field holding the {key.removesuffix('_field')}",
            0,
        )
    return f.get(name)


def _ranges(
    path: Path,
    topics: TopicsMapping,
    plan: Plan,
    channels: dict[str, Channel],
    notes: list[str],
) -> RangesRead:
    spec = topics.ranges
    assert spec is not None
    frames = []
    rec_topic: list[np.ndarray] = []
    rec_index: list[np.ndarray] = []
    names = sorted(plan.ranges)
    for k, topic in enumerate(names):
        ch = channels.get(topic)
        if ch is None or not len(ch):
            continue
        where = Locator(str(path), record=_namer(topic))
        f = RosFields(ch, where)
        n = len(ch)
        rng = _field(f, spec.range_field, "range_field", ch, where).astype(np.float64)
        sigma = np.full(n, np.nan)
        if spec.sigma_field is not None:
            sigma = _field(f, spec.sigma_field, "sigma_field", ch, where).astype(np.float64)
        elif ch.schema_name == RANGE and f.has("variance"):
            var = f.get("variance").astype(np.float64)
            sigma = np.where(var > 0, np.sqrt(np.clip(var, 0, None)), np.nan)
        pair = plan.ranges[topic]
        if pair is None:
            ids = [_field(f, str(name), key, ch, where).tolist() for name, key in _id_fields(spec)]
            src, dst = ([str(v) for v in col] for col in ids)
        else:
            src, dst = [pair[0]] * n, [pair[1]] * n
        frames.append(
            pd.DataFrame({"time": f.times(), "from": src, "to": dst, "range": rng, "sigma": sigma})
        )
        rec_topic.append(np.full(n, k))
        rec_index.append(np.arange(n))
    if not frames:
        raise InputError(path, f"no messages on the [topics] ranges topics ('{spec.topic}')")
    frame = pd.concat(frames, ignore_index=True)
    tk, ti = np.concatenate(rec_topic), np.concatenate(rec_index)
    if not spec.by_topic:
        seen = set(frame["from"]) | set(frame["to"])
        err = unused_names(topics, seen | plan.seen)
        if err is not None:
            raise err
    keep = np.isfinite(frame["range"].to_numpy())
    if not keep.all():
        notes.append(
            f"{path}: {int((~keep).sum())} non-finite range(s) left out (REP 117: no detection)"
        )
    for end in ("from", "to"):
        gone = frame[end].map(topics.dropped).to_numpy(dtype=bool)
        keep &= ~gone
    dropped = int(np.isfinite(frame["range"].to_numpy()).sum() - keep.sum())
    if dropped:
        notes.append(f"{path}: {dropped} range(s) of dropped names left out ([topics] drop)")
    # One table in time order (the topics were read one after the other).
    order = np.flatnonzero(keep)
    order = order[np.argsort(frame["time"].to_numpy()[order], kind="stable")]
    frame = frame.iloc[order].reset_index(drop=True)
    tk, ti = tk[order], ti[order]
    for end in ("from", "to"):
        frame[end] = frame[end].map(topics.platform)
    if topics.duplicates_s > 0:
        copy = _copies(frame, topics.duplicates_s)
        if copy.any():
            notes.append(
                f"{path}: {int(copy.sum())} range(s) equal to their pair's previous range "
                f"less than {topics.duplicates_s:g} s before left out as copies "
                "([topics] duplicates_s)"
            )
            frame = frame.loc[~copy].reset_index(drop=True)
            tk, ti = tk[~copy], ti[~copy]
    where = Locator(str(path), record=lambda i: f"{names[tk[i]]} message {ti[i] + 1}")
    if frame.empty:
        raise where.error("no ranges left after [topics] drop; expected at least one range")
    return range_table_from_frame(frame, where)
