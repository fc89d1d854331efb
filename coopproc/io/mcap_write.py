"""Write a session as one MCAP file (JSON or ROS 2 channels; topics as DATA.md says).

The file also carries the session's ``session.toml`` as an attachment named
``session.toml`` (roles, origin, time base and the ``[mcap]`` mapping used), so a single
``.mcap`` reads back to the same session. Log times are the epoch times in nanoseconds
(the session time base must then be non-negative); ROS 2 header stamps hold the same time.
JSON floats are written exactly (shortest round-trip text), so a JSON MCAP reads back to
the same doubles; a ROS 2 NavSatFix carries the exact RTKLIB Q in its status
(:mod:`navsat_status`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
import tomli_w
from mcap.writer import CompressionType
from mcap.writer import Writer as JsonWriter
from mcap_ros2.writer import Writer as Ros2Writer

from coopproc.errors import OutputError
from coopproc.frames import enu2geodetic
from coopproc.io.navsat_status import navsat_status
from coopproc.io.ros2_msgdefs import IMU, NAVSATFIX, ODOMETRY, UWB_RANGE, UWB_RANGE_MAPPING
from coopproc.io.session_toml import McapMapping, session_toml_table
from coopproc.model import Session, Trajectory
from coopproc.sensors import ImuData

__all__ = ["json_lines", "write_mcap"]


def _log_ns(time_s: np.ndarray, what: str) -> np.ndarray:
    if time_s.size and float(np.min(time_s)) < 0:
        raise OutputError(f"{what}: negative times cannot be MCAP log times")
    return np.round(time_s * 1e9).astype(np.int64)


_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


def write_mcap(
    session: Session,
    path: str | Path,
    *,
    encoding: Literal["json", "ros2"] = "json",
    compression: Literal["zstd", "lz4", "none"] = "zstd",
    reference_llh: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write ``session`` as one MCAP file (chunks compressed as given); returns the path.

    ``reference_llh``: per platform, the (n, 3) latitude, longitude (deg) and height (m)
    of its reference epochs, written into the ROS 2 NavSatFix messages as they are
    instead of converted from ENU (e.g. the values of the .pos file the session was read
    from: ENU -> geodetic -> ENU moves a position by up to ~3 nm, enough to change the
    6th decimal of an output now and then).
    """
    p = Path(path)
    if compression not in _COMPRESSION:
        raise OutputError(f"compression {compression!r}; expected zstd, lz4 or none")
    chunks = _COMPRESSION[compression]
    mapping = McapMapping(**(UWB_RANGE_MAPPING if encoding == "ros2" else {}))
    defaults = McapMapping()
    mcap_table = {
        f.name: getattr(mapping, f.name)
        for f in dataclasses.fields(mapping)
        if getattr(mapping, f.name) != getattr(defaults, f.name)
    }
    config = dataclasses.replace(session.config, mcap=mcap_table, platforms=dict(session.platforms))
    toml_text = tomli_w.dumps(session_toml_table(config, session.origin_llh)).encode()
    with open(p, "wb") as fh:
        if encoding == "json":
            _write_json(session, JsonWriter(fh, compression=chunks), mapping, toml_text)
        else:
            writer = Ros2Writer(fh, compression=chunks)
            _write_ros2(session, writer, mapping, toml_text, reference_llh or {})
    return p


def _write_json(
    session: Session, writer: JsonWriter, mapping: McapMapping, toml_text: bytes
) -> None:
    writer.start(profile="", library="coopproc")
    writer.add_attachment(0, 0, "session.toml", "application/toml", toml_text)
    schema_id = writer.register_schema(name="", encoding="", data=b"")

    def channel(topic: str) -> int:
        return writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id)

    def emit(topic: str, frame: Any, time_s: np.ndarray) -> None:
        cid = channel(topic)
        log = _log_ns(time_s, topic)
        for seq, (line, t) in enumerate(zip(json_lines(frame), log, strict=True)):
            writer.add_message(cid, int(t), line.encode(), int(t), seq)

    for pid in sorted(session.nav):
        traj = session.nav[pid]
        emit(mapping.nav_topic.format(id=pid), traj.frame(), traj.time_s)
    for pid in sorted(session.reference):
        traj = session.reference[pid]
        emit(mapping.reference_topic.format(id=pid), traj.frame(), traj.time_s)
    ranges = session.ranges.frame.drop(columns=["pair"])
    if len(ranges):
        emit(mapping.range_topic, ranges, ranges["time"].to_numpy())
    for pid in sorted(session.imu):
        emit(
            mapping.imu_topic.format(id=pid), _imu_frame(session.imu[pid]), session.imu[pid].time_s
        )
    for pid in sorted(session.odometer):
        odo = session.odometer[pid]
        frame = pd.DataFrame({"time": odo.time_s, "speed": odo.speed_mps})
        if odo.yaw_rate_radps is not None:
            frame["yaw_rate"] = odo.yaw_rate_radps
        emit(mapping.odometer_topic.format(id=pid), frame, odo.time_s)
    writer.finish()


def _imu_frame(imu: ImuData) -> pd.DataFrame:
    frame = pd.DataFrame({"time": imu.time_s})
    for k, axis in enumerate("xyz"):
        frame[f"gyro_{axis}"] = imu.gyro_radps[:, k]
    for k, axis in enumerate("xyz"):
        frame[f"accel_{axis}"] = imu.accel_mps2[:, k]
    return frame


def _write_ros2_sensors(
    session: Session, writer: Ros2Writer, mapping: McapMapping, odom: Any
) -> None:
    """sensor_msgs/msg/Imu and the odometer as nav_msgs/msg/Odometry twists (body frame)."""
    imu_def = writer.register_msgdef("sensor_msgs/msg/Imu", IMU)
    zeros9 = [0.0] * 9
    for pid in sorted(session.imu):
        imu = session.imu[pid]
        topic = mapping.imu_topic.format(id=pid)
        for i, t in enumerate(_log_ns(imu.time_s, topic)):
            g, a = imu.gyro_radps[i], imu.accel_mps2[i]
            msg = {
                "header": {"stamp": _stamp(float(imu.time_s[i])), "frame_id": pid},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0},
                "orientation_covariance": [-1.0, *zeros9[1:]],  # REP 145: no orientation
                "angular_velocity": {"x": float(g[0]), "y": float(g[1]), "z": float(g[2])},
                "angular_velocity_covariance": zeros9,
                "linear_acceleration": {"x": float(a[0]), "y": float(a[1]), "z": float(a[2])},
                "linear_acceleration_covariance": zeros9,
            }
            writer.write_message(topic, imu_def, msg, int(t), int(t), i)
    still = {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
             "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}}  # fmt: skip
    for pid in sorted(session.odometer):
        odo = session.odometer[pid]
        topic = mapping.odometer_topic.format(id=pid)
        known = odo.yaw_rate_radps is not None
        yaw = np.zeros(len(odo.time_s)) if odo.yaw_rate_radps is None else odo.yaw_rate_radps
        cov = [0.0] * 36
        if not known:  # no yaw rate: its variance -1 (unknown), read back as none
            cov[35] = -1.0
        for i, t in enumerate(_log_ns(odo.time_s, topic)):
            twist = {
                "linear": {"x": float(odo.speed_mps[i]), "y": 0.0, "z": 0.0},
                "angular": {"x": 0.0, "y": 0.0, "z": float(yaw[i])},
            }
            msg = {
                "header": {"stamp": _stamp(float(odo.time_s[i])), "frame_id": "odom"},
                "child_frame_id": pid,
                "pose": {"pose": still, "covariance": [0.0] * 36},
                "twist": {"twist": twist, "covariance": cov},
            }
            writer.write_message(topic, odom, msg, int(t), int(t), i)


def _json_values(column: pd.Series) -> list[str]:
    if pd.api.types.is_bool_dtype(column):
        return ["true" if v else "false" for v in column.tolist()]
    if pd.api.types.is_integer_dtype(column):
        return [str(v) for v in column.tolist()]
    if pd.api.types.is_float_dtype(column):
        # repr: the shortest text that parses back to the same double (17 digits at most);
        # pandas' to_json stops at 15 significant digits.
        return [repr(v) if math.isfinite(v) else "null" for v in column.tolist()]
    return [json.dumps(v) if isinstance(v, str) else "null" for v in column.tolist()]


def json_lines(frame: pd.DataFrame) -> list[str]:
    """One flat JSON object per row, floats written exactly (they read back bit for bit)."""
    keys = (json.dumps(str(c)).replace("%", "%%") + ":%s" for c in frame.columns)
    template = "{" + ",".join(keys) + "}"
    columns = [_json_values(frame[c]) for c in frame.columns]
    return [template % row for row in zip(*columns, strict=True)]


def _stamp(t: float) -> dict[str, int]:
    sec = math.floor(t)
    nanosec = round((t - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": int(sec), "nanosec": int(nanosec)}


def _quaternion(heading_deg: float) -> dict[str, float]:
    # ENU yaw (counter-clockwise from east) = 90 deg - heading (clockwise from north).
    yaw = math.radians(90.0 - heading_deg)
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def _odometry(traj: Trajectory, i: int, frame_id: str) -> dict[str, Any]:
    pose_cov = [0.0] * 36
    if traj.sigma_enu_m is not None:
        for k in range(3):
            pose_cov[7 * k] = float(traj.sigma_enu_m[i, k]) ** 2
    zero_q = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
    orient = zero_q if traj.heading_deg is None else _quaternion(float(traj.heading_deg[i]))
    vel = (0.0, 0.0, 0.0) if traj.vel_enu_mps is None else traj.vel_enu_mps[i]
    e, n, u = (float(v) for v in traj.enu_m[i])
    return {
        "header": {"stamp": _stamp(float(traj.time_s[i])), "frame_id": "enu"},
        "child_frame_id": frame_id,
        "pose": {
            "pose": {"position": {"x": e, "y": n, "z": u}, "orientation": orient},
            "covariance": pose_cov,
        },
        "twist": {
            "twist": {
                "linear": {"x": float(vel[0]), "y": float(vel[1]), "z": float(vel[2])},
                "angular": {"x": 0.0, "y": 0.0, "z": 0.0},
            },
            "covariance": [0.0] * 36,
        },
    }


def _write_ros2(
    session: Session,
    writer: Ros2Writer,
    mapping: McapMapping,
    toml_text: bytes,
    reference_llh: Mapping[str, np.ndarray],
) -> None:
    writer.add_attachment(0, 0, "session.toml", "application/toml", toml_text)
    odom = writer.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY)
    fix = writer.register_msgdef("sensor_msgs/msg/NavSatFix", NAVSATFIX)
    rng = writer.register_msgdef("coopproc_msgs/msg/UwbRange", UWB_RANGE)
    for pid in sorted(session.nav):
        traj = session.nav[pid]
        topic = mapping.nav_topic.format(id=pid)
        for i, t in enumerate(_log_ns(traj.time_s, topic)):
            writer.write_message(topic, odom, _odometry(traj, i, pid), int(t), int(t), i)
    for pid in sorted(session.reference):
        traj = session.reference[pid]
        topic = mapping.reference_topic.format(id=pid)
        llh = reference_llh.get(pid)
        if llh is None:
            llh = enu2geodetic(traj.enu_m, session.origin_llh)
        elif np.shape(llh) != traj.enu_m.shape:
            raise OutputError(
                f"reference_llh of {pid}: shape {np.shape(llh)}; expected {traj.enu_m.shape}"
            )
        for i, t in enumerate(_log_ns(traj.time_s, topic)):
            cov = [0.0] * 9
            if traj.sigma_enu_m is not None:
                for k in range(3):
                    cov[4 * k] = float(traj.sigma_enu_m[i, k]) ** 2
            status, service = navsat_status(None if traj.quality is None else traj.quality[i])
            msg = {
                "header": {"stamp": _stamp(float(traj.time_s[i])), "frame_id": pid},
                "status": {"status": status, "service": service},
                "latitude": float(llh[i, 0]),
                "longitude": float(llh[i, 1]),
                "altitude": float(llh[i, 2]),
                "position_covariance": cov,
                "position_covariance_type": 2 if traj.sigma_enu_m is not None else 0,
            }
            writer.write_message(topic, fix, msg, int(t), int(t), i)
    frame = session.ranges.frame
    if len(frame):
        times = frame["time"].to_numpy(dtype=np.float64)
        log = _log_ns(times, mapping.range_topic)
        src, dst = frame["from"].to_numpy(), frame["to"].to_numpy()
        rng_m, sig = frame["range"].to_numpy(), frame["sigma"].to_numpy(dtype=np.float64)
        for i in range(len(frame)):
            msg = {
                "header": {"stamp": _stamp(float(times[i])), "frame_id": "uwb"},
                "from_id": str(src[i]),
                "to_id": str(dst[i]),
                "range": float(rng_m[i]),
                "sigma": float(sig[i]),
            }
            writer.write_message(mapping.range_topic, rng, msg, int(log[i]), int(log[i]), i)
    _write_ros2_sensors(session, writer, mapping, odom)
    writer.finish()
