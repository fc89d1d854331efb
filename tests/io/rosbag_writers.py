"""Small ROS bags written in the tests (rosbags writers): one recording, three bag forms.

Platforms A and B: Odometry nav at 10 Hz (A east at 1 m/s, B parked 5 m north), a
NavSatFix reference for A, sensor_msgs/Range on ``/uwb/{from}/{to}/range`` at 2 Hz, an
IMU on ``/A/imu``; plus a custom range message type for the field-by-field mapping.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

T0 = 1_700_000_000.0
N_NAV = 50  # 5 s at 10 Hz
RANGE_TIMES = T0 + 0.05 + np.arange(10) * 0.5

CUSTOM_MSG = "uint8 src\nuint8 dst\nfloat64 dist\nfloat32 std\nstd_msgs/Header header\n"


def nav_enu(pid: str, t: np.ndarray) -> np.ndarray:
    """The true ENU position of A or B at times t."""
    if pid == "A":
        return np.column_stack([t - T0, np.zeros_like(t), np.full_like(t, 0.2)])
    return np.column_stack([np.zeros_like(t), np.full_like(t, 5.0), np.full_like(t, 0.2)])


def true_range(t: np.ndarray) -> np.ndarray:
    return np.linalg.norm(nav_enu("A", t) - nav_enu("B", t), axis=1)


class _Msgs:
    """Message builders over one typestore (ROS 1 headers carry a seq)."""

    def __init__(self, store: Typestore, ros1: bool) -> None:
        self.store, self.ros1, self.t = store, ros1, store.types

    def header(self, t: float) -> Any:
        sec = int(np.floor(t))
        stamp = self.t["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((t - sec) * 1e9))
        extra = {"seq": 0} if self.ros1 else {}
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id="map", **extra)

    def vec(self, x: float, y: float, z: float) -> Any:
        return self.t["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def quat(self, yaw_enu_deg: float) -> Any:
        h = np.radians(yaw_enu_deg) / 2
        return self.t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=np.sin(h), w=np.cos(h))

    def odometry(self, t: float, enu: np.ndarray) -> Any:
        t_ = self.t
        pose = t_["geometry_msgs/msg/Pose"](
            position=t_["geometry_msgs/msg/Point"](x=enu[0], y=enu[1], z=enu[2]),
            orientation=self.quat(0.0),
        )
        cov = np.zeros(36)
        cov[[0, 7, 14]] = 0.01
        twist = t_["geometry_msgs/msg/Twist"](linear=self.vec(0, 0, 0), angular=self.vec(0, 0, 0))
        return t_["nav_msgs/msg/Odometry"](
            header=self.header(t),
            child_frame_id="base",
            pose=t_["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
            twist=t_["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
        )

    def navsatfix(self, t: float, llh: tuple[float, float, float]) -> Any:
        t_ = self.t
        status = t_["sensor_msgs/msg/NavSatStatus"](status=2, service=1)
        return t_["sensor_msgs/msg/NavSatFix"](
            header=self.header(t),
            status=status,
            latitude=llh[0],
            longitude=llh[1],
            altitude=llh[2],
            position_covariance=np.full(9, 0.0004),
            position_covariance_type=2,
        )

    def range(self, t: float, value: float) -> Any:
        kw: dict[str, Any] = dict(
            header=self.header(t),
            radiation_type=2,
            field_of_view=0.0,
            min_range=0.0,
            max_range=100.0,
            range=value,
        )
        if "variance" in dict(self.store.fielddefs["sensor_msgs/msg/Range"][1]):
            kw["variance"] = 0.0
        return self.t["sensor_msgs/msg/Range"](**kw)

    def imu(self, t: float) -> Any:
        t_ = self.t
        return t_["sensor_msgs/msg/Imu"](
            header=self.header(t),
            orientation=self.quat(0.0),
            orientation_covariance=np.zeros(9),
            angular_velocity=self.vec(0.0, 0.0, 0.1),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=self.vec(0.0, 0.0, 9.81),
            linear_acceleration_covariance=np.zeros(9),
        )


Message = tuple[str, str, float, Any]  # topic, type, log time, message


def recording(m: _Msgs, *, zero_stamp_nav_b: bool = False) -> list[Message]:
    """Every message of the test recording (log time = stamp + 10 ms)."""
    out: list[Message] = []
    t_nav = T0 + np.arange(N_NAV) * 0.1
    for pid in ("A", "B"):
        for t, enu in zip(t_nav, nav_enu(pid, t_nav), strict=True):
            msg = m.odometry(0.0 if (zero_stamp_nav_b and pid == "B") else t, enu)
            out.append((f"/{pid}/odom", "nav_msgs/msg/Odometry", t + 0.01, msg))
    for t in t_nav[::2]:
        lat, lon = 34.0 + (t - T0) * 1e-5, 113.0
        out.append(
            ("/A/fix", "sensor_msgs/msg/NavSatFix", t + 0.01, m.navsatfix(t, (lat, lon, 50.0)))
        )
    for k, (t, r) in enumerate(zip(RANGE_TIMES, true_range(RANGE_TIMES), strict=True)):
        topic = "/uwb/A/B/range" if k % 2 == 0 else "/uwb/B/A/range"
        out.append((topic, "sensor_msgs/msg/Range", t + 0.01, m.range(t, float(np.float32(r)))))
    for t in T0 + np.arange(N_NAV * 10) * 0.01:  # 100 Hz, as IMUs are (DATA.md: 50-1000 Hz)
        out.append(("/A/imu", "sensor_msgs/msg/Imu", t + 0.01, m.imu(t)))
    return sorted(out, key=lambda x: x[2])


def write_ros2(
    path: Path,
    messages: Callable[[_Msgs], list[Message]] = recording,
    *,
    mcap: bool = False,
    version: int = 9,
    store: Typestore | None = None,
) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = store or get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
    conns: dict[str, Any] = {}
    with Writer(path, version=version, storage_plugin=plugin) as w:  # type: ignore[arg-type]
        for topic, msgtype, t, msg in messages(_Msgs(store, ros1=False)):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=store)
            w.write(conns[topic], round(t * 1e9), store.serialize_cdr(msg, msgtype))
    return path


def write_ros1(
    path: Path,
    messages: Callable[[_Msgs], list[Message]] = recording,
    store: Typestore | None = None,
) -> Path:
    from rosbags.rosbag1 import Writer

    store = store or get_typestore(Stores.ROS1_NOETIC)
    conns: dict[str, Any] = {}
    with Writer(path) as w:
        for topic, msgtype, t, msg in messages(_Msgs(store, ros1=True)):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=store)
            w.write(conns[topic], round(t * 1e9), store.serialize_ros1(msg, msgtype))
    return path


def custom_store(base: Stores) -> Typestore:
    """A typestore with ``vendor_msgs/msg/Uwb`` (integer ids, range and sigma fields)."""
    from rosbags.typesys import get_types_from_msg

    store = get_typestore(base)
    store.register(get_types_from_msg(CUSTOM_MSG, "vendor_msgs/msg/Uwb"))
    return store


def custom_recording(m: _Msgs) -> list[Message]:
    """Nav of platforms 1 and 2 (as A and B above) and ranges in vendor_msgs/msg/Uwb."""
    out = []
    t_nav = T0 + np.arange(N_NAV) * 0.1
    for pid, name in (("A", "1"), ("B", "2")):
        for t, enu in zip(t_nav, nav_enu(pid, t_nav), strict=True):
            out.append((f"/r{name}/odom", "nav_msgs/msg/Odometry", t + 0.01, m.odometry(t, enu)))
    uwb = m.store.types["vendor_msgs/msg/Uwb"]
    for k, (t, r) in enumerate(zip(RANGE_TIMES, true_range(RANGE_TIMES), strict=True)):
        src, dst = (1, 2) if k % 2 == 0 else (2, 1)
        msg = uwb(src=src, dst=dst, dist=float(r), std=0.1, header=m.header(t))
        out.append(("/uwb", "vendor_msgs/msg/Uwb", t + 0.01, msg))
    return sorted(out, key=lambda x: x[2])


def pose_recording(m: _Msgs) -> list[Message]:
    """The test recording plus B's pose (PoseStamped, yaw 30 deg ENU) on ``/B/pose``."""
    out = recording(m)
    t_pose = T0 + np.arange(N_NAV) * 0.1
    t_ = m.t
    for t, enu in zip(t_pose, nav_enu("B", t_pose) + np.array([0.0, 0.01, 0.0]), strict=True):
        pose = t_["geometry_msgs/msg/Pose"](
            position=t_["geometry_msgs/msg/Point"](x=enu[0], y=enu[1], z=enu[2]),
            orientation=m.quat(30.0),
        )
        msg = t_["geometry_msgs/msg/PoseStamped"](header=m.header(t), pose=pose)
        out.append(("/B/pose", "geometry_msgs/msg/PoseStamped", t + 0.01, msg))
    return sorted(out, key=lambda x: x[2])
