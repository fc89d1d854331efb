"""ROS bags written in the tests: the three bag forms, the [topics] mapping, bad input."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from rosbags.typesys import Stores

from coopproc.cli import main
from coopproc.errors import CoopprocError, InputError
from coopproc.frames import geodetic2enu
from coopproc.io import read_session, validate_session
from coopproc.io.rosbag_read import read_bag
from coopproc.io.session_toml import parse_session_toml
from coopproc.io.topics_toml import parse_topics
from tests.io.rosbag_writers import (
    RANGE_TIMES,
    T0,
    custom_recording,
    custom_store,
    nav_enu,
    pose_recording,
    recording,
    true_range,
    write_ros1,
    write_ros2,
)

TOPICS = """
[time]
base = "unix"

[topics]
nav = "/{id}/odom"
reference = { A = "/A/fix" }
ranges = "/uwb/{from}/{to}/range"
imu = "/{id}/imu"
"""


def _session(tmp_path: Path, form: str, toml: str = TOPICS, **kw: object) -> Path:
    root = tmp_path / f"s_{form}"
    root.mkdir(parents=True)
    if form == "ros1":
        write_ros1(root / "rec.bag", **kw)  # type: ignore[arg-type]
    else:
        write_ros2(root / "rec", mcap=form == "mcap", **kw)  # type: ignore[arg-type]
    (root / "session.toml").write_text(toml)
    return root


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("bags")
    return {form: _session(tmp, form) for form in ("db3", "mcap", "ros1")}


@pytest.mark.parametrize("form", ["db3", "mcap", "ros1"])
def test_a_bag_session_gives_nav_reference_ranges_and_imu(bags: dict[str, Path], form: str) -> None:
    s = read_session(bags[form])
    assert sorted(s.platforms) == ["A", "B"]
    t_nav = T0 + np.arange(50) * 0.1
    for pid in ("A", "B"):
        nav = s.nav[pid]
        np.testing.assert_allclose(nav.time_s, t_nav, atol=1e-6)  # header stamps, not log times
        np.testing.assert_allclose(nav.enu_m, nav_enu(pid, t_nav), atol=1e-9)
        np.testing.assert_allclose(nav.sigma_enu_m, 0.1)  # sqrt of the covariance diagonal
        np.testing.assert_allclose(nav.heading_deg, 90.0)  # ENU yaw 0 = east = 90 deg from north
    ref = s.reference["A"]
    assert ref.time_s.size == 25
    origin = (34.0, 113.0, 50.0)  # the first reference fix
    assert s.origin_llh == pytest.approx(origin)
    expect = geodetic2enu(
        np.column_stack([34.0 + (ref.time_s - T0) * 1e-5, [113.0] * 25, [50.0] * 25]), origin
    )
    np.testing.assert_allclose(ref.enu_m, expect, atol=1e-9)
    np.testing.assert_allclose(ref.sigma_enu_m, 0.02)
    assert set(ref.quality) == {1}  # NavSatStatus 2 (GBAS) -> Q 1
    f = s.ranges.frame
    np.testing.assert_allclose(f["time"], RANGE_TIMES, atol=1e-6)
    np.testing.assert_allclose(f["range"], true_range(RANGE_TIMES), atol=1e-6)
    assert list(f["from"][:2]) == ["A", "B"] and set(f["pair"]) == {"A-B"}
    assert f["sigma"].isna().all()
    assert [(x.kind, x.platform) for x in s.sensor_files] == [("imu", "A")]
    assert any("/A/imu: IMU samples of A read (500 rates at 100 Hz" in n for n in s.notes)
    assert s.imu["A"].time_s.size == 500 and s.imu["A"].rate_hz == pytest.approx(100.0)
    np.testing.assert_allclose(s.imu["A"].accel_mps2, [[0.0, 0.0, 9.81]] * 500)
    assert s.config.time_base == "unix"
    assert all(p.is_file() for p in s.inputs)


def test_the_three_forms_give_the_same_session(bags: dict[str, Path]) -> None:
    ref = read_session(bags["db3"])
    for form in ("mcap", "ros1"):
        s = read_session(bags[form])
        assert s.ranges.frame.equals(ref.ranges.frame)
        for pid in ("A", "B"):
            np.testing.assert_array_equal(s.nav[pid].enu_m, ref.nav[pid].enu_m)
            np.testing.assert_array_equal(s.nav[pid].time_s, ref.nav[pid].time_s)
        np.testing.assert_array_equal(s.reference["A"].enu_m, ref.reference["A"].enu_m)


def test_imu_samples_are_read_into_arrays(bags: dict[str, Path]) -> None:
    content = read_bag(bags["db3"] / "rec", parse_topics({"imu": "/{id}/imu"}))
    imu = content.imu["A"]
    assert imu.topic == "/A/imu" and imu.time_s.size == 500
    np.testing.assert_allclose(imu.gyro_radps, [[0.0, 0.0, 0.1]] * 500)
    np.testing.assert_allclose(imu.accel_mps2, [[0.0, 0.0, 9.81]] * 500)


@pytest.mark.parametrize("form", ["db3", "ros1"])
def test_pose_stamped_is_east_north_up_with_a_heading(tmp_path: Path, form: str) -> None:
    toml = TOPICS.replace('reference = { A = "/A/fix" }', 'reference = "/{id}/pose"')
    s = read_session(_session(tmp_path, form, toml, messages=pose_recording))
    ref = s.reference["B"]
    t = T0 + np.arange(50) * 0.1
    np.testing.assert_allclose(ref.time_s, t, atol=1e-6)
    np.testing.assert_allclose(ref.enu_m, nav_enu("B", t) + np.array([0.0, 0.01, 0.0]), atol=1e-9)
    np.testing.assert_allclose(ref.heading_deg, 60.0)  # ENU yaw 30 deg = 60 deg from north
    assert ref.sigma_enu_m is None and sorted(s.reference) == ["B"]
    assert s.origin_llh == (0.0, 0.0, 0.0)  # all ENU: the files' own frame


def test_zero_header_stamp_falls_back_to_the_log_time(tmp_path: Path) -> None:
    root = _session(tmp_path, "db3", messages=lambda m: recording(m, zero_stamp_nav_b=True))
    s = read_session(root)
    np.testing.assert_allclose(s.nav["B"].time_s, T0 + np.arange(50) * 0.1 + 0.01, atol=1e-6)
    np.testing.assert_allclose(s.nav["A"].time_s, T0 + np.arange(50) * 0.1, atol=1e-6)


def test_rename_and_drop(tmp_path: Path) -> None:
    toml = TOPICS.replace('reference = { A = "/A/fix" }', 'reference = { tb1 = "/A/fix" }')
    toml += '\n[topics.rename]\nA = "tb1"\nB = "tb2"\n'
    s = read_session(_session(tmp_path, "db3", toml))
    assert sorted(s.platforms) == ["tb1", "tb2"] and set(s.ranges.frame["pair"]) == {"tb1-tb2"}
    assert sorted(s.reference) == ["tb1"] and sorted(s.nav) == ["tb1", "tb2"]
    assert [x.platform for x in s.sensor_files] == ["tb1"]
    drop = TOPICS.replace("[topics]\n", '[topics]\ndrop = ["B"]\n')
    msg = _one_line_error(_session(tmp_path / "d", "db3", drop))
    assert msg.endswith("no ranges left after [topics] drop; expected at least one range")


def test_duplicates_keep_the_first_of_equal_ranges(tmp_path: Path) -> None:
    def doubled(m):  # type: ignore[no-untyped-def]
        out = recording(m)
        extra = []
        for topic, msgtype, t, msg in out:
            if topic == "/uwb/A/B/range":  # the same value again, from B, 40 us later
                copy = m.range(t - 0.01 + 40e-6, msg.range)
                extra.append(("/uwb/B/A/range", msgtype, t + 40e-6, copy))
        return sorted(out + extra, key=lambda x: x[2])

    all_rows = read_session(_session(tmp_path, "db3", messages=doubled))
    assert len(all_rows.ranges.frame) == 15
    toml = TOPICS.replace("[topics]\n", "[topics]\nduplicates_s = 0.005\n")
    s = read_session(_session(tmp_path / "x", "db3", toml, messages=doubled))
    f = s.ranges.frame
    assert len(f) == 10 and list(f["from"]) == ["A", "B"] * 5  # the first of each copy kept
    assert any("5 range(s) equal to their pair's previous range" in n for n in s.notes)


def test_custom_range_message_mapped_field_by_field(tmp_path: Path) -> None:
    toml = """
[topics]
nav = "/r{id}/odom"
[topics.ranges]
topic = "/uwb"
from_field = "src"
to_field = "dst"
range_field = "dist"
sigma_field = "std"
[topics.rename]
1 = "A"
2 = "B"
"""
    for form, store in (("db3", Stores.ROS2_HUMBLE), ("ros1", Stores.ROS1_NOETIC)):
        root = _session(
            tmp_path / form, form, toml, messages=custom_recording, store=custom_store(store)
        )
        s = read_session(root)
        f = s.ranges.frame
        assert list(f["from"][:2]) == ["A", "B"] and len(f) == 10
        np.testing.assert_allclose(f["range"], true_range(RANGE_TIMES), atol=1e-12)
        np.testing.assert_allclose(f["sigma"], 0.1, rtol=1e-6)
    bad = toml.replace('range_field = "dist"', 'range_field = "distance"')
    with pytest.raises(
        InputError, match=r"has no field 'distance' \(\[topics\] ranges range_field\)"
    ):
        read_session(
            _session(
                tmp_path / "bad",
                "db3",
                bad,
                messages=custom_recording,
                store=custom_store(Stores.ROS2_HUMBLE),
            )
        )


def test_no_topics_table_uses_the_suggestion(tmp_path: Path) -> None:
    root = _session(tmp_path, "db3", '[time]\nbase = "unix"\n')
    s = read_session(root)
    assert sorted(s.nav) == ["A", "B"] and sorted(s.reference) == ["A"]
    assert len(s.ranges.frame) == 10
    assert any("no [topics] in session.toml: the suggested mapping used" in n for n in s.notes)


def test_a_bag_file_or_folder_is_a_session_by_itself(bags: dict[str, Path]) -> None:
    for path in (bags["ros1"] / "rec.bag", bags["db3"] / "rec"):
        s = read_session(path)
        assert sorted(s.nav) == ["A", "B"] and len(s.ranges.frame) == 10


def _one_line_error(path: Path) -> str:
    with pytest.raises(CoopprocError) as info:
        read_session(path)
    msg = str(info.value)
    assert "\n" not in msg and "Traceback" not in msg
    return msg


def test_truncated_and_corrupt_bags_are_one_line_errors(
    tmp_path: Path, bags: dict[str, Path]
) -> None:
    bag = tmp_path / "cut.bag"
    data = (bags["ros1"] / "rec.bag").read_bytes()
    bag.write_bytes(data[: len(data) // 2])
    assert _one_line_error(bag).startswith(f"{bag}: cannot open the bag (")
    folder = tmp_path / "cut"
    shutil.copytree(bags["db3"] / "rec", folder)
    db3 = next(folder.glob("*.db3"))
    db3.write_bytes(db3.read_bytes()[:3000])
    msg = _one_line_error(folder)
    assert (
        msg.startswith(f"{folder}: cannot ")
        and "expected a ROS 1 .bag file or a ROS 2 bag folder" in msg
    )
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    assert _one_line_error(folder).startswith(f"{folder}: cannot open the bag (")
    garbage = tmp_path / "junk.bag"
    garbage.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    assert _one_line_error(garbage).startswith(f"{garbage}: cannot open the bag (")
    result = CliRunner().invoke(main, ["info", str(garbage)])
    assert result.exit_code == 1 and result.output.count("\n") == 1
    assert result.output.startswith(f"error: {garbage}: cannot open the bag")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            ('nav = "/{id}/odom"', 'nav = "/{id}/odometry"'),
            r"session.toml \[topics\] nav: '/\{id\}/odometry' matches no topic of .*rec "
            r"\(nearest: '/A/odom'\)",
        ),
        (
            ('reference = { A = "/A/fix" }', 'reference = { A = "/A/gps/fix" }'),
            r"\[topics\] reference A: no topic '/A/gps/fix' in .*rec \(nearest: '/A/fix'\)",
        ),
        (
            ('ranges = "/uwb/{from}/{to}/range"', 'ranges = "/uwb/{from}/{to}/distance"'),
            r"\[topics\] ranges: '/uwb/\{from\}/\{to\}/distance' matches no topic of .*rec "
            r"\(nearest: '/uwb/A/B/range'\)",
        ),
        (
            ('ranges = "/uwb/{from}/{to}/range"', 'ranges = "/uwb/{from}/range"'),
            r"ranges: '/uwb/\{from\}/range' has placeholders \{from\}; expected both",
        ),
        (
            ('nav = "/{id}/odom"', 'nav = "/{id}/imu"'),
            r"rec: /A/imu is sensor_msgs/msg/Imu; expected nav_msgs/msg/Odometry or",
        ),
        (
            ('nav = "/{id}/odom"', 'nva = "/{id}/odom"'),
            r"\[topics\]: unknown key 'nva' \(did you mean 'nav'\?\)",
        ),
        (
            ("[topics]\n", '[topics]\ndrop = ["AA"]\n'),
            r"\[topics\] drop: 'AA' is not a name in the mapped topics \(did you mean 'A'\?\)",
        ),
        (("[topics]\n", "[topics]\nduplicates_s = -1\n"), r"duplicates_s: -1; expected seconds"),
        (
            ("[topics]\n", '[topics]\nbag = "recc"\n'),
            r"\[topics\] bag: 'recc' is not a bag in .* \(did you mean 'rec'\?\)",
        ),
    ],
)
def test_mapping_errors_name_the_nearest(
    tmp_path: Path, change: tuple[str, str], message: str
) -> None:
    toml = TOPICS.replace(*change)
    assert toml != TOPICS
    root = _session(tmp_path, "db3", toml)
    msg = _one_line_error(root)
    assert __import__("re").search(message, msg), msg
    assert validate_session(root)  # validate lists it too


def test_range_topics_outside_the_pattern_are_noted(tmp_path: Path) -> None:
    def with_sonar(m):  # type: ignore[no-untyped-def]
        out = recording(m)
        out += [
            ("/sonar/front", "sensor_msgs/msg/Range", T0 + k, m.range(T0 + k, 1.0))
            for k in range(3)
        ]
        return sorted(out, key=lambda x: x[2])

    s = read_session(_session(tmp_path, "db3", messages=with_sonar))
    assert len(s.ranges.frame) == 10
    note = f"{s.root / 'rec'}: 1 sensor_msgs/msg/Range topic(s) do not match [topics] ranges"
    assert any(n.startswith(note) and n.endswith("not used: /sonar/front") for n in s.notes)


def test_two_bags_need_topics_bag(tmp_path: Path, bags: dict[str, Path]) -> None:
    root = tmp_path / "two"
    shutil.copytree(bags["db3"], root)
    shutil.copy(bags["ros1"] / "rec.bag", root / "other.bag")
    assert "several bags (other.bag, rec); expected one, or [topics] bag" in _one_line_error(root)
    toml = (root / "session.toml").read_text().replace("[topics]\n", '[topics]\nbag = "other"\n')
    (root / "session.toml").write_text(toml)
    assert sorted(read_session(root).nav) == ["A", "B"]


def test_topics_without_a_bag_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "session.toml").write_text(TOPICS)
    msg = _one_line_error(tmp_path)
    assert "[topics]: given, but" in msg and "holds no ROS bag" in msg


def test_info_lists_topics_and_suggests_a_mapping(bags: dict[str, Path]) -> None:
    result = CliRunner().invoke(main, ["info", str(bags["ros1"] / "rec.bag")])
    assert result.exit_code == 0, result.output
    out = result.output
    assert "(ROS 1, 6 topics, 635 messages, 5.0 s; rates from log times)" in out
    row = next(line for line in out.splitlines() if line.strip().startswith("/A/odom"))
    assert row.split() == ["/A/odom", "nav_msgs/msg/Odometry", "50", "10.00", "nav", "A"]
    suggested = out.split("check it):\n", 1)[1].split("\nsession ", 1)[0]
    assert 'nav = "/{id}/odom"' in suggested and 'ranges = "/uwb/{from}/{to}/range"' in suggested
    assert 'imu = { A = "/A/imu" }' in suggested and 'reference = { A = "/A/fix" }' in suggested
    parsed = parse_session_toml(suggested)  # what info prints is valid session.toml
    assert parsed.topics is not None and parsed.topics.nav == "/{id}/odom"
    assert "\nsession rec" in out and "pairs (10 ranges)" in out


def test_info_on_a_session_directory_shows_the_mapping_then_the_session(
    bags: dict[str, Path],
) -> None:
    result = CliRunner().invoke(main, ["info", str(bags["db3"])])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].startswith(f"bag {bags['db3'] / 'rec'}  (ROS 2 sqlite3, 6 topics, 635 ")
    assert lines[1].split() == ["topic", "type", "messages", "rate_hz", "mapped"]
    roles = {line.split()[0]: " ".join(line.split()[4:]) for line in lines[2:8]}
    assert roles == {
        "/A/fix": "reference A",
        "/A/imu": "imu A",
        "/A/odom": "nav A",
        "/B/odom": "nav B",
        "/uwb/A/B/range": "ranges A-B",
        "/uwb/B/A/range": "ranges B-A",
    }
    assert "not a complete session" not in result.output
    assert "pairs (10 ranges)" in result.output
