"""Simulated IMU and odometer (coopproc.sim.imu): consistent with the truth, errors of the
grade, files only when asked (default runs unchanged)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from coopproc.errors import ConfigError
from coopproc.io import read_session
from coopproc.report.allan import axis_allan
from coopproc.sensors import IMU_GRADE_FIGURES
from coopproc.sim import simulate, write_simulation
from coopproc.sim.imu import (
    EARTH_RATE_RADPS,
    ImuTruth,
    add_raw_sensors,
    imu_errors,
    imu_truth,
    normal_gravity,
    odometer_samples,
)

RATE = 100.0


@pytest.fixture(scope="module")
def sim():  # type: ignore[no-untyped-def]
    return simulate("paper-experiment", duration_s=120.0)


def _rot(yaw: float, pitch: float) -> np.ndarray:
    """C_b^n = Rz(yaw) Ry(-pitch)."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]])
    return rz @ ry


def _ideal(sim, pid: str, earth: bool, rate: float = RATE) -> ImuTruth:  # type: ignore[no-untyped-def]
    truth = sim.truth.trajectories[pid]
    t = truth.time_s[0] + np.arange(int(120.0 * rate)) / rate
    return imu_truth(truth, t, sim.session.origin_llh, earth)


def test_specific_force_and_rates_reproduce_the_truth_derivatives(sim) -> None:  # type: ignore[no-untyped-def]
    g = normal_gravity(sim.session.origin_llh[0], sim.session.origin_llh[2])
    for pid in ("A", "B", "C"):
        ideal = _ideal(sim, pid, earth=False, rate=400.0)
        dt = 1.0 / 400.0
        acc = np.gradient(ideal.vel_enu_mps, dt, axis=0)
        for k in range(100, ideal.time_s.size - 100, 397):
            f_n = _rot(ideal.yaw_rad[k], ideal.pitch_rad[k]) @ ideal.accel_mps2[k]
            np.testing.assert_allclose(f_n - [0, 0, g], acc[k], atol=2e-4)
        yaw_rate = np.gradient(ideal.yaw_rad, dt)
        turning = ideal.gyro_radps[:, 2] / np.cos(ideal.pitch_rad)
        inner = slice(400, -400)
        assert np.max(np.abs(turning[inner] - yaw_rate[inner])) < 1e-3
        # the earth rate is in the gyros only when asked for
        earth = _ideal(sim, pid, earth=True, rate=400.0)
        w = np.linalg.norm(earth.gyro_radps - ideal.gyro_radps, axis=1)
        np.testing.assert_allclose(w, EARTH_RATE_RADPS, rtol=1e-9)


def _strapdown(ideal: ImuTruth, g: float) -> np.ndarray:
    """A flat-earth strapdown integrator: rotation vector attitude, trapezoid velocity."""
    dt = float(ideal.time_s[1] - ideal.time_s[0])
    c = _rot(ideal.yaw_rad[0], ideal.pitch_rad[0])
    v, p = ideal.vel_enu_mps[0].copy(), ideal.enu_m[0].copy()
    out = np.empty_like(ideal.enu_m)
    out[0] = p
    f_prev = c @ ideal.accel_mps2[0]
    for k in range(1, ideal.time_s.size):
        phi = 0.5 * (ideal.gyro_radps[k - 1] + ideal.gyro_radps[k]) * dt
        a = np.linalg.norm(phi)
        skew = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
        if a > 0:
            skew2 = skew @ skew
            c = c @ (np.eye(3) + np.sin(a) / a * skew + (1 - np.cos(a)) / a**2 * skew2)
        f = c @ ideal.accel_mps2[k]
        v_new = v + 0.5 * (f_prev + f) * dt - np.array([0, 0, g]) * dt
        p = p + 0.5 * (v + v_new) * dt
        v, f_prev = v_new, f
        out[k] = p
    return out


def test_noiseless_imu_integrates_back_to_the_truth(sim) -> None:  # type: ignore[no-untyped-def]
    """What is left is the integrator's own error: it falls with dt^2 (16 x from 100 to
    400 Hz), so the IMU itself is consistent with the trajectory."""
    lat, _, h = sim.session.origin_llh
    g = float(normal_gravity(lat, h))
    truth = sim.truth.trajectories["C"]  # the follower with the sharpest turns
    worst = {}
    for rate in (100.0, 400.0):
        ideal = _ideal(sim, "C", earth=False, rate=rate)
        every = int(rate)
        at = truth.interpolate(ideal.time_s[::every])
        worst[rate] = np.linalg.norm(_strapdown(ideal, g)[::every] - at, axis=1).max()
        assert np.sum(np.linalg.norm(np.diff(at, axis=0), axis=1)) > 40.0
    assert worst[400.0] < 0.01  # 1 cm after 120 s and > 40 m
    assert 10.0 < worst[100.0] / worst[400.0] < 25.0


def test_noisy_imu_gives_back_the_grade_in_allan_deviation() -> None:
    n = int(1800 * RATE)
    t = np.arange(n) / RATE
    g = 9.8
    zeros = np.zeros((n, 3))
    up = np.tile([0.0, 0.0, g], (n, 1))
    still = ImuTruth(t, zeros, up, zeros, zeros, np.zeros(n), np.zeros(n))
    for name in ("consumer", "industrial", "tactical"):
        grade = IMU_GRADE_FIGURES[name]
        gyro, accel, draws = imu_errors(still, grade, RATE, np.random.default_rng(5))
        assert set(draws) >= {"gyro_turn_on_x", "accel_scale_ppm_z"}
        for k, axis in enumerate("xyz"):
            arw = axis_allan("gyro", axis, gyro[:, k], RATE).random_walk
            vrw = axis_allan("accel", axis, accel[:, k], RATE).random_walk
            assert arw == pytest.approx(grade.gyro_arw, rel=0.2), (name, axis)
            assert vrw == pytest.approx(grade.accel_vrw, rel=0.2), (name, axis)
        # the turn-on bias is there: the mean differs from the truth by about its size
        bias = np.abs(gyro.mean(axis=0)) * 180 / np.pi * 3600
        assert np.all(bias < 5 * (grade.gyro_turn_on + grade.gyro_bias))
        assert np.any(bias > 0.05 * grade.gyro_turn_on)


def test_odometer_is_the_forward_speed_scaled(sim) -> None:  # type: ignore[no-untyped-def]
    truth = sim.truth.trajectories["A"]
    t = truth.time_s[0] + np.arange(1200) / 10.0
    clean = odometer_samples(truth, t, 0.0, 0.0, np.random.default_rng(0))
    ideal = _ideal(sim, "A", earth=False)
    np.testing.assert_allclose(clean, np.linalg.norm(ideal.vel_enu_mps[::10], axis=1), atol=1e-9)
    scaled = odometer_samples(truth, t, 0.01, 0.0, np.random.default_rng(0))
    np.testing.assert_allclose(scaled, 1.01 * clean, rtol=1e-12)
    noisy = odometer_samples(truth, t, 0.0, 0.005, np.random.default_rng(0))
    sigma = 0.005 * np.sqrt(np.abs(clean) * 0.1) / 0.1
    z = (noisy - clean)[clean > 0.3] / sigma[clean > 0.3]
    assert 0.85 < np.std(z) < 1.15


def test_files_round_trip_and_default_is_off(sim, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    assert add_raw_sensors(sim) is sim and len(sim.truth.imu_errors) == 0  # default: off
    assert not sim.session.imu and not sim.session.odometer
    on = simulate("paper-experiment", duration_s=60.0, imu_rate_hz=200.0, imu_grade="tactical")
    table = on.truth.imu_errors
    assert sorted(on.session.imu) == ["A", "B", "C"] and list(table["grade"]) == ["tactical"] * 3
    with_imu = on
    files = write_simulation(on, tmp_path / "s")
    names = {p.name for p in files}
    assert {"imu_A.csv", "odo_C.csv", "imu_errors.csv"} <= names
    back = read_session(tmp_path / "s")
    imu, odo = back.imu["B"], back.odometer["B"]
    assert imu.rate_hz == pytest.approx(200.0) and imu.time_s.size == 60 * 200 + 1
    np.testing.assert_allclose(imu.gyro_radps, with_imu.session.imu["B"].gyro_radps, atol=5e-7)
    np.testing.assert_allclose(odo.speed_mps, with_imu.session.odometer["B"].speed_mps, atol=5e-7)
    dr = back.odometer["A"]  # the dead-reckoning odometer scale is the one used
    scale = float(table.set_index("platform").loc["A", "odo_scale"])
    assert scale == float(on.truth.dr_params.set_index("platform").loc["A", "odo_scale"])
    assert dr.rate_hz == pytest.approx(10.0)


def test_imu_options_are_checked() -> None:
    with pytest.raises(ConfigError, match="imu_rate_hz"):
        simulate("paper-experiment", duration_s=30.0, imu_rate_hz=20.0)
    with pytest.raises(ConfigError, match="imu_grade"):
        simulate("paper-experiment", duration_s=30.0, imu_rate_hz=100.0, imu_grade="good")
    with pytest.raises(ConfigError, match=r"imu_grade.*does nothing without IMU data"):
        simulate("paper-experiment", duration_s=30.0, imu_grade="tactical")


@pytest.mark.parametrize("encoding", ["json", "ros2"])
def test_mcap_carries_the_imu_and_odometer(tmp_path: Path, encoding: str) -> None:
    """simulate --imu --mcap: sensor_msgs/Imu and Odometry twists (or JSON) read back
    to the numbers of the CSV files."""
    on = simulate("paper-experiment", duration_s=20.0, imu_rate_hz=100.0)
    write_simulation(on, tmp_path / "s", mcap=True, mcap_encoding=encoding)  # type: ignore[arg-type]
    files = read_session(tmp_path / "s")
    mcap = read_session(tmp_path / "s" / "mcap" / "paper-experiment.mcap")
    assert sorted(mcap.imu) == sorted(files.imu) == ["A", "B", "C"]
    for pid in files.imu:
        a, b = files.imu[pid], mcap.imu[pid]
        np.testing.assert_array_equal(a.time_s, b.time_s)
        np.testing.assert_array_equal(a.gyro_radps, b.gyro_radps)
        np.testing.assert_array_equal(a.accel_mps2, b.accel_mps2)
        c, d = files.odometer[pid], mcap.odometer[pid]
        np.testing.assert_array_equal(c.speed_mps, d.speed_mps)
        assert d.yaw_rate_radps is None  # the simulated odometer gives no yaw rate
