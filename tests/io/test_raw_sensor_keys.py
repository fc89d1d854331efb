"""DATA.md "Raw sensors": the platform keys of session.toml, the raw-sensor files, tags;
and the shared real sessions read as they are."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.io import read_session, validate_session, write_session
from coopproc.model import ImuNoise, SensorFile

SENSOR_KEYS = """
wheelbase = 0.35
uwb_lever_arm = [0.0, 0.0, 0.4]
gnss_lever_arm = [0.2, 0.0, 0.9]
imu_mounting = [0.0, 0.0, 90.0]
nhc = true

[platforms.A.imu]
grade = "industrial"
gyro_noise = 0.0035
accel_noise = 0.0006
gyro_bias = 10.0
accel_bias = 0.5
correlation_time = 3600.0
"""

NOT_USED = "recognised but not used by this version of coopproc"


def _add_to_a(sample_dir: Path, text: str) -> Path:
    """Append ``text`` to the [platforms.A] table of the session.toml."""
    toml = sample_dir / "session.toml"
    body = toml.read_text()
    assert "[platforms.A]\n" in body
    head, tail = body.split("[platforms.A]\n", 1)
    first, _, rest = tail.partition("\n[")
    toml.write_text(f"{head}[platforms.A]\n{first}\n{text}\n[{rest}")
    return toml


@pytest.fixture(scope="module")
def real_data() -> Path:
    """The shared real sessions (``shared/data`` beside the repository)."""
    path = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real"
    if not (path / "tuc" / "session.toml").is_file():
        pytest.skip("shared/data/real is not present")
    return path


def test_sensor_keys_are_read_checked_and_written_back(sample_dir: Path, tmp_path: Path) -> None:
    _add_to_a(sample_dir, SENSOR_KEYS)
    session = read_session(sample_dir)
    a = session.platforms["A"]
    assert a.role == "follower" and a.drift_sigma_mps == 0.02
    assert a.wheelbase_m == 0.35
    assert a.uwb_lever_arm_m == (0.0, 0.0, 0.4)
    assert a.gnss_lever_arm_m == (0.2, 0.0, 0.9)
    assert a.imu_mounting_deg == (0.0, 0.0, 90.0)
    assert a.nhc is True
    assert a.imu == ImuNoise("industrial", 0.0035, 0.0006, 10.0, 0.5, 3600.0)
    assert session.platforms["B"].wheelbase_m is None and session.platforms["B"].imu is None
    write_session(session, tmp_path / "copy")
    assert read_session(tmp_path / "copy").platforms["A"] == a


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("wheelbse = 0.35", "[platforms.A]: unknown key 'wheelbse' (did you mean 'wheelbase'?)"),
        ("nhc = 1", "[platforms.A] nhc: expected true or false, found 1"),
        ("wheelbase = 350", "[platforms.A] wheelbase: 350.0; expected metres, 0 < wheelbase <= 10"),
        (
            "uwb_lever_arm = [0.0, 40.0, 0.0]",
            "[platforms.A] uwb_lever_arm: [0.0, 40.0, 0.0]; "
            "expected [x, y, z] in metres, each within +-10",
        ),
        ("gnss_lever_arm = [0.2, 0.9]", "[platforms.A] gnss_lever_arm: expected 3 values, found 2"),
        (
            "imu_mounting = [0.0, 0.0, 400.0]",
            "[platforms.A] imu_mounting: [0.0, 0.0, 400.0]; "
            "expected [roll, pitch, yaw] in degrees, each within +-360",
        ),
        (
            "[platforms.A.imu]\ngyro_nose = 0.1",
            "[platforms.A.imu]: unknown key 'gyro_nose' (did you mean 'gyro_noise'?)",
        ),
        (
            "[platforms.A.imu]\ngyro_bias = -1.0",
            "[platforms.A.imu] gyro_bias: -1.0; expected deg/h, > 0 and <= 36000",
        ),
        (
            "[platforms.A.imu]\naccel_bias = 2000.0",
            "[platforms.A.imu] accel_bias: 2000.0; expected mg, > 0 and <= 1000",
        ),
        (
            '[platforms.A.imu]\ngrade = "tactcal"',
            "[platforms.A.imu] grade: 'tactcal' (did you mean 'tactical'?); "
            "expected one of consumer | industrial | tactical | navigation",
        ),
    ],
)
def test_bad_sensor_keys_are_one_line_errors(sample_dir: Path, text: str, message: str) -> None:
    toml = _add_to_a(sample_dir, text)
    assert validate_session(sample_dir) == [f"{toml} {message}"]
    with pytest.raises(ConfigError):
        read_session(sample_dir)


def _imu_odo_files(sample_dir: Path) -> None:
    """imu_A.csv (100 Hz at rest) and odo_B.csv.gz (10 Hz) over the sample session's start."""
    t = 432000.0 + np.arange(1000) / 100.0
    rng = np.random.default_rng(0)
    imu = pd.DataFrame({"time": t})
    for i, axis in enumerate("xyz"):
        imu[f"gyro_{axis}"] = rng.normal(0.0, 1e-3, t.size)
        imu[f"accel_{axis}"] = rng.normal(0.0, 0.01, t.size) + (9.80665 if i == 2 else 0.0)
    imu.to_csv(sample_dir / "imu_A.csv", index=False)
    odo = pd.DataFrame({"time": t[::10], "speed": 0.5})
    odo.to_csv(sample_dir / "odo_B.csv.gz", index=False)


def test_raw_sensor_files_are_listed_and_noted_once(sample_dir: Path, tmp_path: Path) -> None:
    _imu_odo_files(sample_dir)
    # GNSS files are read too (tests/gnss/test_tight.py, test_gnss_session_errors)
    (sample_dir / "imu.txt").write_text("not a sensor file name\n")
    session = read_session(sample_dir)
    assert sorted(session.platforms) == ["A", "B", "C", "X"]
    assert session.sensor_files == (
        SensorFile("imu", sample_dir / "imu_A.csv", "A"),
        SensorFile("odo", sample_dir / "odo_B.csv.gz", "B"),
    )
    assert sorted(session.imu) == ["A"] and sorted(session.odometer) == ["B"]
    assert session.imu["A"].time_s.size == 1000 and session.imu["A"].static_fraction == 1.0
    np.testing.assert_allclose(session.odometer["B"].speed_mps, 0.5)
    read = "for the INS methods with ranges to anchors (ins*)"
    expected = [
        f"note: {sample_dir / 'imu_A.csv'}: IMU samples of A read (1000 rates at 100 Hz, "
        f"10.0 s); {read}",
        f"note: {sample_dir / 'odo_B.csv.gz'}: odometer speeds of B read (100 at 10 Hz, "
        "9.9 s); for odo_uwb with ranges to anchors and an IMU (the yaw rate)",
    ]
    res = CliRunner().invoke(main, ["validate", str(sample_dir)])
    assert res.exit_code == 0
    assert res.output.splitlines() == [*expected, f"{sample_dir}: ok"]
    # `coopproc info` lists them among the reader notes, once each
    info = CliRunner().invoke(main, ["info", str(sample_dir)])
    assert info.exit_code == 0
    for line in expected:
        assert info.output.count(line.removeprefix("note: ")) == 1


def test_raw_sensor_files_of_unknown_platforms_and_bad_files_are_errors(sample_dir: Path) -> None:
    _imu_odo_files(sample_dir)
    (sample_dir / "imu_A.csv").rename(sample_dir / "imu_Z.csv")
    frame = pd.read_csv(sample_dir / "odo_B.csv.gz")
    frame.loc[5, "time"] = frame.loc[3, "time"]
    frame.to_csv(sample_dir / "odo_B.csv", index=False)
    (sample_dir / "odo_B.csv.gz").unlink()
    assert validate_session(sample_dir) == [
        f"{sample_dir / 'imu_Z.csv'}: IMU samples of platform Z, which the session does not "
        "have (platforms: A, B, C, X); expected nav_Z.csv or [platforms.Z] in session.toml",
        f"{sample_dir / 'odo_B.csv'}:7: time 432000.3 is before the previous sample's "
        "432000.4; expected increasing times",
    ]


def test_tag_is_read_and_run_with_a_note(sample_dir: Path, tmp_path: Path) -> None:
    toml = sample_dir / "session.toml"
    toml.write_text(toml.read_text() + '\n[platforms.T]\nrole = "tag"\n')
    with (sample_dir / "ranges.csv").open("a") as f:
        f.write("432001.500000,T,X,3.0,,-70.0\n432002.500000,A,T,4.0,,-71.0\n")
    session = read_session(sample_dir)
    assert session.platforms["T"].role == "tag" and "T" not in session.nav
    assert "T-X" in session.ranges.pairs
    res = CliRunner().invoke(main, ["validate", str(sample_dir)])
    sorted_note = f"note: {sample_dir / 'ranges.csv'}: times not in order; rows sorted by time"
    assert (res.exit_code, res.output) == (0, f"{sorted_note}\n{sample_dir}: ok\n")
    # coopproc run positions tags by the UWB-only methods (coopproc.run.tags); this one
    # ranges to one anchor only, so it gets no fix, and says so
    res = CliRunner().invoke(
        main, ["run", str(sample_dir), "-o", str(tmp_path / "out"), "--no-figures"]
    )
    assert res.exit_code == 0, res.output
    assert "note: tag T (no navigation of its own): UWB-only positioning lsq, lsq_rts" in (
        res.output
    )
    assert "note: tag T: no observed fix (never ranged to enough anchors" in res.output
    ranges = pd.read_csv(tmp_path / "out" / "ranges.csv")
    tag_rows = ranges[ranges["pair"].isin(["T-X", "A-T"])]
    assert len(tag_rows) == 2 and tag_rows["di"].isna().all()
    # a tag has no navigation file by definition
    (sample_dir / "nav_T.csv").write_text((sample_dir / "nav_C.csv").read_text())
    assert validate_session(sample_dir) == [
        'session.toml: [platforms.T] role = "tag": T has a navigation file, but a tag has no '
        "navigation of its own; expected role follower or leader"
    ]


def test_real_tuc_session_reads_validates_and_runs(real_data: Path, tmp_path: Path) -> None:
    tuc = real_data / "tuc"
    session = read_session(tuc)
    robot = session.platforms["robot"]
    assert robot.wheelbase_m == 0.0785 and robot.drift_sigma_mps == 0.251
    assert session.sensor_files == (SensorFile("odo", tuc / "odo_robot.csv", "robot"),)
    note = (
        f"{tuc / 'odo_robot.csv'}: odometer wheel speeds of robot read (233 at 7.813 Hz, "
        "29.8 s); for odo_uwb with ranges to anchors"
    )
    assert session.odometer["robot"].form == "wheels"
    res = CliRunner().invoke(main, ["validate", str(tuc)])
    assert res.exit_code == 0
    assert res.output.splitlines() == [f"note: {note}", f"{tuc}: ok"]
    res = CliRunner().invoke(main, ["run", str(tuc), "-o", str(tmp_path / "out"), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert res.output.count(note) == 1
    assert "frame of its own" not in res.output and "excluded" not in res.output
    positions = pd.read_csv(tmp_path / "out" / "positions.csv")
    assert set(positions["platform"]) == {"robot"}  # the odometer file made no platform


def test_real_tiers_session_validates_without_warnings(real_data: Path) -> None:
    tiers = real_data / "tiers"
    res = CliRunner().invoke(main, ["validate", str(tiers)])
    extra = (
        f"note: {tiers / 'ranges.csv'}: extra column 'range_raw_ds' carried through as is "
        "(did you mean 'range'?)"
    )
    assert (res.exit_code, res.output) == (0, f"{extra}\n{tiers}: ok\n")


def test_platform_defaults_are_unchanged() -> None:
    from coopproc.model import Platform

    p = Platform("A")
    # + max_motion, antenna (height, planar)
    assert dataclasses.astuple(p)[4:] == (None,) * 6 + ((None, None, None), (None, None))


def test_a_z_down_imu_is_an_error_unless_its_mounting_is_given(sample_dir: Path) -> None:
    _imu_odo_files(sample_dir)
    frame = pd.read_csv(sample_dir / "imu_A.csv")
    frame[["accel_y", "accel_z"]] *= -1.0  # x forward, y right, z down
    frame.to_csv(sample_dir / "imu_A.csv", index=False)
    (problem,) = validate_session(sample_dir)
    assert problem.startswith(f"{sample_dir / 'imu_A.csv'}: at rest the accelerometers read")
    assert "gravity along -z, a z-down body frame" in problem
    _add_to_a(sample_dir, "imu_mounting = [180.0, 0.0, 0.0]")
    assert read_session(sample_dir).imu["A"].accel_mps2[:, 2].mean() < -9.0
