"""IMU and odometry from ROS bags (sensor_msgs/msg/Imu, nav_msgs/msg/Odometry twist) read
as the session's raw sensors, through [topics] (ROS 2 mcap storage and ROS 1)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from coopproc.io import read_session, validate_session
from coopproc.io.topics_toml import parse_topics
from tests.io.rosbag_writers import T0, recording, write_ros1, write_ros2

TOPICS = """
[time]
base = "unix"

[topics]
nav = "/{id}/odom"
ranges = "/uwb/{from}/{to}/range"
imu = "/{id}/imu"
odometer = "/{id}/odom"
"""


def _speed(t: np.ndarray) -> np.ndarray:
    return 0.5 + 0.1 * (t - T0)


def with_twist(m: Any) -> list[Any]:
    """The test recording with the odometry's twist filled: linear.x, angular.z."""
    out = []
    for topic, msgtype, t, msg in recording(m):
        if msgtype == "nav_msgs/msg/Odometry":
            stamp = t - 0.01
            twist = m.t["geometry_msgs/msg/Twist"](
                linear=m.vec(float(_speed(np.array(stamp))), 0.0, 0.0),
                angular=m.vec(0.0, 0.0, -0.05 if topic == "/A/odom" else 0.02),
            )
            msg.twist.twist = twist
        out.append((topic, msgtype, t, msg))
    return out


@pytest.mark.parametrize("form", ["mcap", "ros1"])
def test_imu_and_odometer_topics_become_the_sessions_raw_sensors(tmp_path: Path, form: str) -> None:
    root = tmp_path / form
    root.mkdir()
    if form == "ros1":
        write_ros1(root / "rec.bag", with_twist)
    else:
        write_ros2(root / "rec", with_twist, mcap=True)
    (root / "session.toml").write_text(TOPICS)
    s = read_session(root)
    assert sorted(s.imu) == ["A"] and sorted(s.odometer) == ["A", "B"]
    a = s.odometer["A"]
    assert a.form == "twist" and a.rate_hz == pytest.approx(10.0, rel=1e-3)
    t0 = float(a.time_s[0])
    np.testing.assert_allclose(a.speed_mps, 0.5 + 0.1 * (a.time_s - t0), atol=1e-6)
    assert a.yaw_rate_radps is not None and s.odometer["B"].yaw_rate_radps is not None
    np.testing.assert_allclose(a.yaw_rate_radps, -0.05)
    np.testing.assert_allclose(s.odometer["B"].yaw_rate_radps, 0.02)
    assert s.imu["A"].rate_hz == pytest.approx(100.0, rel=1e-3)
    np.testing.assert_allclose(s.imu["A"].gyro_radps, [[0.0, 0.0, 0.1]] * 500)
    assert any("odometer twists of B read (50 at 10 Hz" in n for n in s.notes)


def test_odometer_topic_of_the_wrong_type_or_unknown_platform(tmp_path: Path) -> None:
    root = tmp_path / "s"
    root.mkdir()
    write_ros2(root / "rec", with_twist, mcap=True)
    (root / "session.toml").write_text(
        TOPICS.replace('odometer = "/{id}/odom"', 'odometer = "/{id}/imu"')
    )
    (problem,) = validate_session(root)
    assert (
        "/A/imu is sensor_msgs/msg/Imu; expected nav_msgs/msg/Odometry for [topics] odometer"
        in problem
    )
    (root / "session.toml").write_text(
        TOPICS.replace('odometer = "/{id}/odom"', 'odometer = { Q = "/B/odom" }')
    )
    (problem,) = validate_session(root)
    assert "/B/odom) of platform Q, which the session does not have (platforms: A, B)" in problem
    assert problem.startswith(f"{root / 'rec'}: odometry (")
    assert parse_topics({"odometer": "/{id}/odom"}).odometer == "/{id}/odom"  # type: ignore[union-attr]
