"""MCAP files written in the tests with the mcap / mcap_ros2 writers (JSON and ROS 2)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import tomli_w
from mcap.writer import Writer
from mcap_ros2.writer import Writer as Ros2Writer

from coopproc.io import read_session, validate_session
from coopproc.io.mcap_json import fast_json_frame
from coopproc.io.mcap_scan import scan_mcap
from coopproc.io.ros2_msgdefs import NAVSATFIX, ODOMETRY

T0 = 432000.0
TOML = {
    "time": {"base": "gps_tow", "gps_week": 2178},
    "frame": {"origin": [34.798, 113.659, 110.0]},
    "platforms": {"A": {"role": "leader"}, "B": {"role": "follower"}},
}

# A vendor range message: other field names, ids as integers, nested range.
RANGE_MSGDEF = (
    "std_msgs/Header header\nuint8 tag_id\nuint8 anchor_id\nRangeValue value\n"
    + "=" * 80
    + "\nMSG: vendor_msgs/RangeValue\nfloat32 distance\nfloat32 quality\n"
    + "=" * 80
    + "\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    + "=" * 80
    + "\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
)


def _stamp(t: float) -> dict[str, int]:
    sec = int(np.floor(t))
    return {"sec": sec, "nanosec": round((t - sec) * 1e9)}


def _odom(t: float, e: float, n: float) -> dict[str, Any]:
    zero3 = {"x": 0.0, "y": 0.0, "z": 0.0}
    return {
        "header": {"stamp": _stamp(t), "frame_id": "enu"},
        "child_frame_id": "base",
        "pose": {
            "pose": {"position": {"x": e, "y": n, "z": 0.0}, "orientation": {**zero3, "w": 0.0}},
            "covariance": [0.0] * 36,
        },
        "twist": {"twist": {"linear": zero3, "angular": zero3}, "covariance": [0.0] * 36},
    }


def test_ros2_custom_range_message_mapped_in_session_toml(tmp_path: Path) -> None:
    path = tmp_path / "rec.mcap"
    with open(path, "wb") as fh:
        w = Ros2Writer(fh)
        odom = w.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY)
        fix = w.register_msgdef("sensor_msgs/msg/NavSatFix", NAVSATFIX)
        rng = w.register_msgdef("vendor_msgs/msg/UwbRange", RANGE_MSGDEF)
        for i in range(30):
            t = T0 + 0.1 * i
            log = int((t + 0.05) * 1e9)  # log times lag the stamps: stamps must win
            w.write_message("/robot_1/odom", odom, _odom(t, 0.5 * i, 0.0), log, log, i)
            w.write_message("/robot_2/odom", odom, _odom(t, 0.5 * i, 4.0), log, log, i)
            if i % 10 == 0:
                msg = {
                    "header": {"stamp": _stamp(t), "frame_id": "uwb"},
                    "tag_id": 1,
                    "anchor_id": 2,
                    "value": {"distance": 4.25, "quality": 0.5},
                }
                w.write_message("/uwb", rng, msg, log, log, i)
            fixmsg = {
                "header": {"stamp": _stamp(t), "frame_id": "gps"},
                "status": {"status": 2 if i != 3 else 0, "service": 1},
                "latitude": 34.798 + 1e-6 * i,
                "longitude": 113.659,
                "altitude": 110.0,
                "position_covariance": [0.0001, 0, 0, 0, 0.0001, 0, 0, 0, 0.0004],
                "position_covariance_type": 2,
            }
            w.write_message("/robot_1/fix", fix, fixmsg, log, log, i)
        w.finish()
    toml: dict[str, Any] = dict(TOML)
    toml["platforms"] = {"1": {"role": "leader"}, "2": {"role": "follower"}}
    toml["mcap"] = {
        "nav_topic": "/robot_{id}/odom",
        "reference_topic": "/robot_{id}/fix",
        "range_topic": "/uwb",
        "from_field": "tag_id",
        "to_field": "anchor_id",
        "range_field": "value.dist",
    }
    (tmp_path / "session.toml").write_text(tomli_w.dumps(toml))
    assert validate_session(tmp_path) == [
        f"{path} (/uwb message 1): vendor_msgs/msg/UwbRange has no field 'value.dist' "
        "(session.toml [mcap] range_field); expected the message field holding the range"
    ]
    toml["mcap"]["range_field"] = "value.distance"
    (tmp_path / "session.toml").write_text(tomli_w.dumps(toml))
    s = read_session(tmp_path)
    np.testing.assert_allclose(s.nav["1"].time_s, T0 + 0.1 * np.arange(30), atol=1e-9)
    np.testing.assert_allclose(s.nav["2"].enu_m[5], [2.5, 4.0, 0.0])
    frame = s.ranges.frame
    assert list(frame["pair"]) == ["1-2"] * 3 and list(frame["from"]) == ["1"] * 3
    np.testing.assert_allclose(frame["range"], 4.25)
    np.testing.assert_allclose(frame["time"], [T0, T0 + 1, T0 + 2], atol=1e-9)
    assert frame["sigma"].isna().all()
    ref = s.reference["1"]
    assert len(ref) == 29  # status 0 (plain fix -> Q 5) dropped by the Q = 1 filter
    np.testing.assert_allclose(ref.sigma_enu_m[0], [0.01, 0.01, 0.02])  # type: ignore[index]
    assert ref.enu_m[2, 1] == pytest.approx(2 * 1e-6 * 110_922.0, abs=0.01)


def test_json_written_with_the_mcap_writer_stamps_and_log_times(tmp_path: Path) -> None:
    path = tmp_path / "rec.mcap"
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="", library="test")
        w.add_attachment(0, 0, "session.toml", "application/toml", tomli_w.dumps(TOML).encode())
        sid = w.register_schema(name="", encoding="", data=b"")
        nav = {p: w.register_channel(f"/{p}/nav", "json", sid) for p in ("A", "B")}
        rng = w.register_channel("/uwb/range", "json", sid)
        other = w.register_channel("/camera/info", "json", sid)
        for i in range(20):
            t = T0 + 0.1 * i
            log = int((T0 + 0.1 * i + 0.05) * 1e9)
            for p, ch in nav.items():
                # A carries its own time key; B has none: the log time is its time.
                body = {"east": float(i), "north": 1.0 if p == "A" else 2.0, "up": 0.0}
                if p == "A":
                    body = {"time": t, **body}
                w.add_message(ch, log, json.dumps(body).encode(), log)
            if i % 5 == 0:
                body2 = {"time": t, "from": "B", "to": "A", "range": 1.0, "rssi": -70 - i}
                w.add_message(rng, log, json.dumps(body2).encode(), log)
            w.add_message(other, log, b'{"w": 640}', log)
        w.finish()
    s = read_session(path)
    np.testing.assert_allclose(s.nav["A"].time_s, T0 + 0.1 * np.arange(20), atol=1e-9)
    np.testing.assert_allclose(s.nav["B"].time_s, T0 + 0.05 + 0.1 * np.arange(20), atol=1e-9)
    assert list(s.ranges.frame["rssi"]) == [-70, -75, -80, -85]
    assert list(s.ranges.frame["pair"]) == ["A-B"] * 4
    assert s.platforms["A"].role == "leader"
    assert any("/camera/info (20 messages) not used" in n for n in s.notes)
    assert s.nav["A"].source == f"{path} /A/nav"


def _channel(tmp_path: Path, messages: list[bytes]) -> Any:
    path = tmp_path / "c.mcap"
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="", library="test")
        sid = w.register_schema(name="", encoding="", data=b"")
        ch = w.register_channel("/x", "json", sid)
        for i, m in enumerate(messages):
            w.add_message(ch, i, m, i)
        w.finish()
    (channel,) = scan_mcap(path).channels.values()
    return channel


def test_fast_json_path_equals_json_loads(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    rows = [
        {"time": float(t), "from": f"P{i % 3:02d}", "to": "01", "range": float(v), "ok": None}
        for i, (t, v) in enumerate(
            zip(rng.uniform(0, 1e6, 500), rng.normal(0, 1e3, 500), strict=True)
        )
    ]
    rows[5]["range"] = float("nan")  # json.dumps writes NaN
    rows[6]["range"] = float("inf")
    rows[7]["from"] = "a, {b}"  # braces inside a string: not the fast path
    ch = _channel(tmp_path, [json.dumps(r).encode() for r in rows])
    assert fast_json_frame(ch) is None
    rows[7]["from"] = "a, b"
    ch = _channel(tmp_path, [json.dumps(r).encode() for r in rows])
    fast = fast_json_frame(ch)
    assert fast is not None
    slow = pd.DataFrame.from_records(rows)
    np.testing.assert_array_equal(fast["time"].to_numpy(), slow["time"].to_numpy())
    np.testing.assert_array_equal(fast["range"].to_numpy(), slow["range"].to_numpy())
    assert list(fast["from"]) == list(slow["from"]) and list(fast["to"]) == ["01"] * 500
    assert fast["ok"].isna().all()


@pytest.mark.parametrize(
    "messages",
    [
        [b'{"a": 1, "b": 2}', b'{"b": 2, "a": 1}'],  # key order differs
        [b'{"a": 1, "b": 2}', b'{"a": 1, "c": 2}'],  # keys differ
        [b'{"a": 1, "b": [1, 2]}', b'{"a": 1, "b": [3]}'],  # nested
        [b'{"a": "x\\"y", "b": 1}', b'{"a": "z", "b": 2}'],  # escapes
        [b'{"a": 1,\n "b": 2}', b'{"a": 3, "b": 4}'],  # newline inside
        [b'{"a": 1, "b": 2}', b'{"a": 1, "b": 2, "a": 5}'],  # duplicated key
    ],
)
def test_fast_json_path_declines_what_it_cannot_do(tmp_path: Path, messages: list[bytes]) -> None:
    assert fast_json_frame(_channel(tmp_path, messages)) is None


@pytest.mark.parametrize("encoding", ["json", "ros2"])
@pytest.mark.parametrize("compression", ["lz4", "none"])
def test_lz4_and_uncompressed_chunks(
    tmp_path: Path, kit: Any, compression: str, encoding: str
) -> None:
    from coopproc.io import write_mcap

    s = kit.make_session()
    path = write_mcap(s, tmp_path / "c.mcap", encoding=encoding, compression=compression)  # type: ignore[arg-type]
    kit.assert_same_session(s, read_session(path))


def test_fixed_layout_cdr_reads_equal_the_ros2_decoder(tmp_path: Path, kit: Any) -> None:
    from coopproc.io import cdr_fast, write_mcap
    from coopproc.io._common import Locator
    from coopproc.io.mcap_ros2_read import RosFields

    raw = scan_mcap(write_mcap(kit.make_session(), tmp_path / "r.mcap", encoding="ros2"))
    paths = {
        "nav_msgs/msg/Odometry": ["pose.pose.position.x", "pose.covariance", "header.stamp.sec"],
        "sensor_msgs/msg/NavSatFix": [
            "latitude",
            "position_covariance",
            "status.status",
            "status.service",
        ],
        "coopproc_msgs/msg/UwbRange": ["from_id", "to_id", "range", "sigma"],
    }
    for ch in raw.channels.values():
        plan = cdr_fast.plan(ch)
        assert plan is not None, ch.topic
        slow = RosFields.__new__(RosFields)
        slow.ch, slow.where, slow.plan = ch, Locator("x"), None
        slow.msgs = slow._decode()
        for path in paths[ch.schema_name]:
            fast_values, slow_values = plan.read(ch, path), slow.get(path)
            if fast_values.dtype == object:
                assert list(fast_values) == list(slow_values)
            else:
                np.testing.assert_array_equal(fast_values, slow_values)


def test_varying_frame_ids_fall_back_to_the_decoder(tmp_path: Path) -> None:
    from coopproc.io import cdr_fast

    path = tmp_path / "v.mcap"
    with open(path, "wb") as fh:
        w = Ros2Writer(fh)
        odom = w.register_msgdef("nav_msgs/msg/Odometry", ODOMETRY)
        for i in range(12):
            msg = _odom(T0 + 0.1 * i, float(i), 0.0)
            msg["child_frame_id"] = "b" * (1 + i % 3)
            w.write_message("/A/nav", odom, msg, int((T0 + 0.1 * i) * 1e9), 0, i)
        w.finish()
    (ch,) = scan_mcap(path).channels.values()
    assert cdr_fast.plan(ch) is None
    from coopproc.io._common import Locator
    from coopproc.io.mcap_ros2_read import ros_trajectory

    raw = ros_trajectory(ch, "A", Locator(str(path)))
    np.testing.assert_allclose(raw.position[:, 0], np.arange(12.0))
    np.testing.assert_allclose(raw.time_s, T0 + 0.1 * np.arange(12), atol=1e-9)
