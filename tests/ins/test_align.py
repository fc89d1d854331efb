"""Coarse alignment and the static-start detector (coopproc.ins.align), and IMU grades."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.errors import StageError
from coopproc.ins.align import coarse_align, heading_from_motion, level, static_start
from coopproc.ins.earth import earth_rate_enu, normal_gravity
from coopproc.ins.models import DEFAULT_GRADE, GRADES, ImuFigures, imu_figures
from coopproc.ins.quat import euler_to_quat, quat_to_dcm
from coopproc.model import ImuNoise

LAT = np.radians(48.0)
RATE = 200.0


def _static_imu(
    roll: float, pitch: float, yaw: float, noise: ImuFigures, seconds: float, seed: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noisy samples of a unit at rest with the grade's random walks and a bias draw."""
    rng = np.random.default_rng(seed)
    k = int(seconds * RATE)
    c = quat_to_dcm(euler_to_quat(roll, pitch, yaw))
    f_b = c.T @ np.array([0.0, 0.0, normal_gravity(LAT, 0.0)])
    w_b = c.T @ earth_rate_enu(LAT)
    sq = np.sqrt(RATE)
    accel = (
        f_b
        + noise.accel_bias_mps2 * rng.normal(size=3)
        + rng.normal(0, noise.vrw_mps_rts * sq, (k, 3))
    )
    gyro = (
        w_b
        + noise.gyro_bias_radps * rng.normal(size=3)
        + rng.normal(0, noise.arw_rad_rts * sq, (k, 3))
    )
    return np.arange(k) / RATE, gyro, accel


@pytest.mark.parametrize(("roll", "pitch"), [(3.0, -5.0), (-20.0, 10.0), (0.0, 0.0)])
def test_levelling_recovers_roll_and_pitch_within_0_1_deg(roll: float, pitch: float) -> None:
    noise = GRADES["industrial"]
    t, gyro, accel = _static_imu(np.radians(roll), np.radians(pitch), 0.7, noise, 30.0)
    al = coarse_align(t, gyro, accel, LAT, noise, yaw=0.7)
    assert np.degrees(al.roll) == pytest.approx(roll, abs=0.1)
    assert np.degrees(al.pitch) == pytest.approx(pitch, abs=0.1)
    assert al.heading_source == "given" and al.yaw == 0.7


def test_level_exact_sign_conventions() -> None:
    # nose down (positive pitch, REP 103): gravity reaction along -x... f_x = -g sin(pitch)
    g = 9.8
    assert level(np.array([-g * np.sin(0.2), 0.0, g * np.cos(0.2)])) == pytest.approx((0.0, 0.2))
    assert level(np.array([0.0, g * np.sin(0.3), g * np.cos(0.3)])) == pytest.approx((0.3, 0.0))


def test_gyrocompassing_with_a_good_gyro() -> None:
    good = GRADES["navigation"]
    t, gyro, accel = _static_imu(np.radians(2.0), np.radians(-1.0), np.radians(125.0), good, 60.0)
    al = coarse_align(t, gyro, accel, LAT, good)
    assert al.heading_source == "gyrocompass"
    assert np.degrees(al.yaw) == pytest.approx(125.0, abs=1.0)


def test_poor_gyro_needs_an_external_heading() -> None:
    poor = GRADES["consumer"]
    t, gyro, accel = _static_imu(0.0, 0.0, 1.0, poor, 20.0)
    with pytest.raises(StageError, match="gyrocompassing"):
        coarse_align(t, gyro, accel, LAT, poor)
    track = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [3.0, 3.0, 0.0]])
    al = coarse_align(t, gyro, accel, LAT, poor, motion=(np.array([20.0, 21.0, 22.0]), track))
    assert al.heading_source == "motion" and al.yaw == pytest.approx(np.pi / 4)


def test_heading_from_motion_waits_for_the_distance() -> None:
    enu = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.5, 0.0]])
    assert heading_from_motion(np.array([0.0, 1.0, 2.0]), enu) == pytest.approx((2.0, np.pi / 2))
    with pytest.raises(StageError, match="never move"):
        heading_from_motion(np.array([0.0, 1.0]), np.zeros((2, 3)))


def test_static_start_detector_finds_the_end_of_rest() -> None:
    noise = GRADES["industrial"]
    t, gyro, accel = _static_imu(0.0, 0.0, 0.0, noise, 20.0)
    moving = t >= 12.0
    accel[moving, 0] += np.sin(2 * np.pi * 1.5 * t[moving])  # driving off
    n = static_start(t, gyro, accel)
    assert 11.0 <= t[n - 1] < 12.0
    with pytest.raises(StageError, match="static for"):
        coarse_align(t[-1000:], gyro[-1000:], accel[-1000:], LAT, noise, yaw=0.0)


def test_imu_figures_from_the_session() -> None:
    """The session's figures override its grade's; no table: the default grade."""
    n = imu_figures(ImuNoise(grade="tactical", gyro_bias_deg_h=2.0))
    assert n.gyro_bias == 2.0 and n.accel_bias == GRADES["tactical"].accel_bias
    assert n.gyro_bias_radps == pytest.approx(np.radians(2.0) / 3600)
    assert imu_figures(None) == GRADES[DEFAULT_GRADE]
    m = imu_figures(ImuNoise(accel_noise_mps_rts=0.01, correlation_time_s=50.0))
    assert (m.accel_noise, m.correlation_time) == (0.01, 50.0)
    assert m.gyro_noise == GRADES[DEFAULT_GRADE].gyro_noise
    q_g, q_a = n.bias_psd()
    assert q_g == pytest.approx(2 * n.gyro_bias_radps**2 / n.correlation_time)
    assert q_a == pytest.approx(2 * n.accel_bias_mps2**2 / n.correlation_time)
    # the initial bias sigma holds the turn-on bias too
    t = GRADES["tactical"]
    assert t.gyro_bias0_radps == pytest.approx(
        np.radians(np.hypot(t.gyro_bias, t.gyro_turn_on)) / 3600
    )
