"""The quadrotor scenario (issue 31 part 3): drones with a consumer IMU among six lab
anchors, ranging one anchor at a time at 2 Hz, no navigation file, no static start; the
multirotor IMU is consistent with the truth (a free INS from the true start stays on it)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from coopproc.frames import EARTH_RATE_RADPS
from coopproc.ins.align import Alignment, static_start
from coopproc.ins.engine import InsAiding, InsConfig, run_ins
from coopproc.ins.models import GRADES
from coopproc.ins.quat import dcm_to_euler
from coopproc.sensors import ImuData
from coopproc.sim.engine import simulate
from coopproc.sim.imu import imu_truth, normal_gravity
from coopproc.sim.multirotor import multirotor_imu

DRONES = ("ifo001", "ifo002", "ifo003")


@pytest.fixture(scope="module")
def sim():  # type: ignore[no-untyped-def]
    return simulate("quadrotor", seed=0, duration_s=40.0)


def test_drones_are_tags_with_a_consumer_imu_and_no_navigation(sim) -> None:  # type: ignore[no-untyped-def]
    s = sim.session
    assert not s.nav and not s.odometer
    for pid in DRONES:
        assert s.platforms[pid].role == "tag"
        assert s.platforms[pid].nhc is False
        assert s.platforms[pid].imu.grade == "consumer"
        imu = s.imu[pid]
        assert np.median(np.diff(imu.time_s)) == pytest.approx(0.005)
        # no static start: moving from the first sample on
        assert static_start(imu.time_s, imu.gyro_radps, imu.accel_mps2) == 0
        truth = sim.truth.trajectories[pid]
        v0 = np.linalg.norm(truth.enu_m[1] - truth.enu_m[0]) / np.diff(truth.time_s[:2])[0]
        assert v0 > 0.1
    anchors = np.array([s.platforms[f"AN{k}"].position_enu_m for k in range(1, 7)])
    assert np.ptp(anchors[:, 2]) > 2.0  # low and high anchors: the height is observable
    assert np.ptp(anchors[:, 0]) > 5.5 and np.ptp(anchors[:, 1]) > 6.5


def test_each_drone_polls_its_anchors_in_turn_at_2_hz(sim) -> None:  # type: ignore[no-untyped-def]
    frame = sim.session.ranges.frame
    for pid in DRONES:
        mine = frame[(frame["from"] == pid) | (frame["to"] == pid)]
        t = np.sort(mine["time"].to_numpy())
        assert np.min(np.diff(t)) == pytest.approx(0.5, abs=1e-6)  # one range at a time
        assert len(t) / 40.0 == pytest.approx(2.0, rel=0.05)  # 2 Hz less the dropouts
        other = mine["to"].where(mine["from"] == pid, mine["from"])
        for anchor in sorted(set(other)):
            ta = np.sort(mine["time"].to_numpy()[other.to_numpy() == anchor])
            assert np.median(np.diff(ta)) == pytest.approx(3.0, abs=1e-6)


def test_multirotor_imu_integrates_to_the_truth(sim) -> None:  # type: ignore[no-untyped-def]
    """The error-free IMU of the tilted, yawing body, mechanized from the true start,
    stays within 2 cm of the truth over 40 s (rates at the sample time instead of the
    interval's middle drift metres: coopproc.sim.multirotor)."""
    s = sim.session
    truth = sim.truth.trajectories["ifo002"]
    t = s.imu["ifo002"].time_s
    ideal = imu_truth(truth, t, s.origin_llh, True, "multirotor")
    spline = CubicSpline(truth.time_s, truth.enu_m, axis=0)
    yaw = CubicSpline(truth.time_s, np.unwrap(np.radians(90.0 - truth.heading_deg)))
    lat = np.radians(s.origin_llh[0])
    w_ie = EARTH_RATE_RADPS * np.array([0.0, np.cos(lat), np.sin(lat)])
    _, accel, c = multirotor_imu(
        spline, yaw, t[:1], lambda up: normal_gravity(s.origin_llh[0], s.origin_llh[2] + up), w_ie
    )
    assert np.abs(accel[0, :2]).max() < 1e-9  # a drag-free multirotor senses its thrust only
    roll, pitch, yaw0 = dcm_to_euler(c[0])
    assert np.hypot(roll, pitch) > np.radians(0.5)  # tilted by its acceleration
    data = ImuData("ifo002", "ideal", t, ideal.gyro_radps, ideal.accel_mps2, "rate", 0.0)
    al = Alignment(roll, pitch, yaw0, "given", 0.01, 0.01, 0)
    cfg = InsConfig(GRADES["consumer"], tuple(s.origin_llh), al, spline(t[0]), spline(t[0], 1))
    res = run_ins(data, InsAiding(), cfg)
    err = np.linalg.norm(res.forward.enu_m - spline(t), axis=1)
    assert err.max() < 0.02, err.max()
