"""An ES-EKF run on a simulated straight road: NHC removes the lateral drift of a biased
IMU (paper 003 section 2.6, Fig. 7)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from coopproc.ins.errorstate import ErrorStateEkf, nav_error
from coopproc.ins.loop import run_filter
from coopproc.ins.models import GRADES
from coopproc.ins.synth import straight_imu
from coopproc.ins.updates import nhc_update, odometer_update

LAT, LON, H = np.radians(48.0), np.radians(11.0), 500.0
DT = 0.005


def _drive(nhc: bool, odometer: bool = False) -> tuple[np.ndarray, ErrorStateEkf]:
    # industrial grade, its turn-on biases at the size of the biases simulated below
    noise = replace(GRADES["industrial"], gyro_turn_on=10.0, accel_turn_on=5.0)
    s = straight_imu(LAT, LON, H, 10.0, 120.0)
    rng = np.random.default_rng(7)
    bias_g = np.radians([10.0, -8.0, 1.0]) / 3600.0
    bias_a = np.array([2e-3, 5e-3, -1e-3]) * 9.80665
    dth = s.dtheta + bias_g * DT + rng.normal(0, noise.arw_rad_rts * np.sqrt(DT), s.dtheta.shape)
    dv = s.dvel + bias_a * DT + rng.normal(0, noise.vrw_mps_rts * np.sqrt(DT), s.dvel.shape)
    ekf = ErrorStateEkf.start(noise, np.full(3, 0.01), np.full(3, 0.01), np.radians([0.05] * 3))

    def aid(k: int, nav: np.ndarray, w_b: np.ndarray) -> list:
        if k % 20:  # 10 Hz
            return []
        out = [nhc_update(nav, w_b, 0.05)] if nhc else []
        if odometer:
            out.append(odometer_update(nav, w_b, 10.0, 0.05))
        return out

    sol = run_filter(s.time_s, dth, dv, s.nav0, ekf, aid if (nhc or odometer) else None)
    truth = straight_imu(LAT, LON, H, 10.0, 120.0)
    from coopproc.ins.mechanize import mechanize

    ref = mechanize(truth.time_s, truth.nav0, truth.dtheta, truth.dvel)
    err = np.array([nav_error(sol.nav[k], ref.nav[k]) for k in range(0, len(s.time_s), 200)])
    return err, ekf


def test_nhc_removes_the_lateral_drift_on_a_straight_road() -> None:
    free, _ = _drive(nhc=False)
    aided, ekf = _drive(nhc=True)
    cross_free = np.abs(free[:, 1]).max()  # north = cross-track of an eastward drive
    cross_nhc = np.abs(aided[:, 1]).max()
    assert cross_free > 100.0
    assert cross_nhc < 0.02 * cross_free
    assert cross_nhc < 3.0
    assert np.abs(aided[:, 2]).max() < 0.1 * np.abs(free[:, 2]).max()  # vertical too
    # the lateral velocity error is held near zero (without NHC it grows without bound)
    assert np.abs(aided[:, 4]).max() < 0.1 < np.abs(free[:, 4]).max()
    # lateral accelerometer bias and roll error both act as lateral specific force; NHC
    # sees their sum: the filter's share of the bias moves towards the true 5 mg
    assert 0.0 < ekf.bias_a[1] < 6e-3 * 9.80665


def test_free_inertial_drift_at_rest_stays_within_the_bias_model() -> None:
    """60 s at rest, tactical grade, biases drawn from the grade: the free-inertial error
    stays inside 3 sigma of the covariance the error-state model propagates (and the
    sigma is what 1/2 b t^2 says)."""
    from coopproc.ins.mechanize import make_nav
    from coopproc.ins.synth import circle_imu

    noise = GRADES["tactical"]
    s = circle_imu(LAT, LON, H, 0.0, 0.0, 60.0)  # at rest, yaw 0
    rng = np.random.default_rng(5)
    bias_g = noise.gyro_bias0_radps * rng.normal(size=3)
    bias_a = noise.accel_bias0_mps2 * rng.normal(size=3)
    dth = s.dtheta + bias_g * DT + rng.normal(0, noise.arw_rad_rts * np.sqrt(DT), s.dtheta.shape)
    dv = s.dvel + bias_a * DT + rng.normal(0, noise.vrw_mps_rts * np.sqrt(DT), s.dvel.shape)
    ekf = ErrorStateEkf.start(noise, np.full(3, 1e-3), np.full(3, 1e-3), np.full(3, 1e-5))
    sol = run_filter(s.time_s, dth, dv, s.nav0, ekf)
    err = nav_error(sol.nav[-1], make_nav(LAT, LON, H, np.zeros(3), 0.0, 0.0, 0.0))
    sigma = np.sqrt(np.diag(ekf.p))[:9]
    assert np.all(np.abs(err) < 3 * sigma)
    half_b_t2 = 0.5 * noise.accel_bias0_mps2 * 60.0**2
    tilt = 9.8 * noise.gyro_bias0_radps * 60.0**3 / 6.0  # a horizontal gyro bias tilts
    assert sigma[0] == pytest.approx(np.hypot(half_b_t2, tilt), rel=0.1)
    assert np.abs(err[:2]).max() > 0.05 * half_b_t2  # and it does drift
