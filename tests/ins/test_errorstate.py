"""The error-state model and measurement Jacobians (coopproc.ins.errorstate, .updates)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from coopproc.ins.errorstate import (
    ATT,
    BA,
    BG,
    POS,
    VEL,
    ErrorStateEkf,
    apply_correction,
    discretize,
    f_matrix,
    inject_error,
    nav_error,
)
from coopproc.ins.mechanize import make_nav, mechanize
from coopproc.ins.models import GRADES
from coopproc.ins.synth import straight_imu
from coopproc.ins.updates import (
    nhc_update,
    odometer_update,
    position_update,
    range_update,
    zero_velocity_update,
)

LAT, LON, H = np.radians(48.0), np.radians(11.0), 500.0
DT = 0.005


def test_f_matrix_predicts_the_mechanization_error() -> None:
    """Errors injected into a straight drive (constant F) evolve as expm(F T) dx0."""
    s = straight_imu(LAT, LON, H, 15.0, 20.0)
    dx0 = np.zeros(15)
    dx0[POS] = [0.3, -0.2, 0.1]
    dx0[VEL] = [0.02, 0.01, -0.01]
    dx0[ATT] = [2e-4, -1e-4, 3e-4]
    dx0[BG] = np.radians([3.0, -2.0, 4.0]) / 3600.0
    dx0[BA] = [2e-3, -1e-3, 1.5e-3]
    truth = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    ins = mechanize(
        s.time_s, inject_error(s.nav0, dx0), s.dtheta + dx0[BG] * DT, s.dvel + dx0[BA] * DT
    )
    f = f_matrix(s.nav0, s.dvel[0] / DT, s.dtheta[0] / DT, 1e9)
    for k in (2000, 4000):
        predicted = (expm(f * s.time_s[k]) @ dx0)[:9]
        actual = nav_error(ins.nav[k], truth.nav[k])
        scale = np.abs(predicted) + np.array([1e-3] * 3 + [1e-4] * 3 + [1e-6] * 3)
        assert np.abs(actual - predicted) / scale == pytest.approx(np.zeros(9), abs=0.02)


def test_discretize_is_second_order() -> None:
    f = np.array([[0.0, 1.0], [-4.0, 0.0]])
    assert discretize(f, 1e-3) == pytest.approx(expm(f * 1e-3), abs=1e-8)
    assert np.abs(discretize(f, 1e-3) - (np.eye(2) + f * 1e-3)).max() > 1e-6


def test_correction_inverts_injection() -> None:
    nav = make_nav(LAT, LON, H, np.array([3.0, -1.0, 0.2]), 0.1, -0.2, 2.0)
    dx = np.zeros(15)
    dx[:9] = [1.0, -2.0, 0.5, 0.1, 0.2, -0.1, 1e-3, -2e-3, 5e-3]
    back = apply_correction(inject_error(nav, dx), dx)
    assert np.abs(nav_error(back, nav)) == pytest.approx(np.zeros(9), abs=1e-6)
    assert nav_error(inject_error(nav, dx), nav) == pytest.approx(dx[:9], rel=1e-5, abs=1e-9)


def _fd_check(h_of_nav, nav: np.ndarray, jac: np.ndarray, cols: slice, step: float) -> None:
    """Columns ``cols`` of the Jacobian against central differences of h(inject_error)."""
    for j in range(cols.start, cols.stop):
        dx = np.zeros(15)
        dx[j] = step
        num = (h_of_nav(inject_error(nav, dx), dx) - h_of_nav(inject_error(nav, -dx), -dx)) / (
            2 * step
        )
        assert num == pytest.approx(jac[:, j], rel=1e-4, abs=2e-6), j


NAV = make_nav(LAT, LON, H, np.array([4.0, 3.0, 0.1]), 0.05, -0.1, 0.8)
LEVER = np.array([0.3, -0.2, 0.9])
W_B = np.array([0.01, -0.02, 0.3])


def test_position_lever_arm_jacobian() -> None:
    meas = NAV[0:3] + np.array([1e-7, -2e-7, 0.3])
    m = position_update(NAV, meas, LEVER, np.ones(3))
    for cols, step in ((POS, 1e-2), (VEL, 1e-3), (ATT, 1e-3)):
        _fd_check(
            lambda nv, _dx: position_update(nv, meas, LEVER, np.ones(3)).v, NAV, m.h, cols, step
        )
    # the lever arm moves the antenna by C l: innovation at the true antenna is zero
    from coopproc.ins.updates import antenna_ecef

    ant, _, _ = antenna_ecef(NAV, LEVER)
    assert np.linalg.norm(ant - antenna_ecef(NAV, np.zeros(3))[0]) == pytest.approx(
        np.linalg.norm(LEVER)
    )


def test_range_lever_arm_jacobian() -> None:
    anchor = NAV[0:3] + np.array([3e-6, -2e-6, 2.0])
    m = range_update(NAV, anchor, LEVER, 30.0, 0.1)
    for cols, step in ((POS, 1e-2), (ATT, 1e-3)):
        _fd_check(
            lambda nv, _dx: range_update(nv, anchor, LEVER, 30.0, 0.1).v, NAV, m.h, cols, step
        )


@pytest.mark.parametrize("kind", ["nhc", "odo"])
def test_body_velocity_jacobians_with_lever_arm(kind: str) -> None:
    def h_of(nv: np.ndarray, dx: np.ndarray) -> np.ndarray:
        w = W_B + dx[BG]  # the INS rate carries the gyro-bias error
        if kind == "nhc":
            return nhc_update(nv, w, 0.1, LEVER).v
        return odometer_update(nv, w, 5.0, 0.1, LEVER).v

    jac = (
        nhc_update(NAV, W_B, 0.1, LEVER)
        if kind == "nhc"
        else odometer_update(NAV, W_B, 5.0, 0.1, LEVER)
    ).h
    for cols, step in ((VEL, 1e-3), (ATT, 1e-5), (BG, 1e-5)):
        _fd_check(h_of, NAV, jac, cols, step)


def test_position_update_and_feedback_remove_a_known_error() -> None:
    truth = make_nav(LAT, LON, H, np.array([1.0, 0.0, 0.0]), 0.0, 0.0, 0.3)
    dx = np.zeros(15)
    dx[POS] = [2.0, -1.0, 0.5]
    dx[VEL] = [0.1, -0.05, 0.0]
    ins = inject_error(truth, dx)
    ekf = ErrorStateEkf.start(
        GRADES["tactical"], np.full(3, 3.0), np.full(3, 0.2), np.full(3, 1e-3)
    )
    ekf.update(position_update(ins, truth[0:3], np.zeros(3), np.full(3, 0.01)))
    ekf.update(zero_velocity_update(ins, 0.001))  # velocity 0 is wrong: use the true one
    fixed = ekf.feedback(ins)
    err = nav_error(fixed, truth)
    assert np.abs(err[POS]).max() < 0.01
    assert np.abs(err[VEL] - (-truth[3:6])).max() < 0.01  # it believed v = 0
    assert not ekf.x.any()


def test_robust_range_update_downweights_a_gross_error() -> None:
    anchor = NAV[0:3] + np.array([3e-6, -2e-6, 2.0])
    true_range = range_update(NAV, anchor, LEVER, 0.0, 0.1).v[0]
    ekf = ErrorStateEkf.start(
        GRADES["tactical"], np.full(3, 0.1), np.full(3, 0.1), np.full(3, 1e-3)
    )
    gamma = ekf.update(range_update(NAV, anchor, LEVER, true_range + 0.05, 0.1), (3.0, 4.5))
    assert gamma[0] == 1.0
    gamma = ekf.update(range_update(NAV, anchor, LEVER, true_range + 5.0, 0.1), (3.0, 4.5))
    assert gamma[0] < 1e-20
    assert np.abs(ekf.x[POS]).max() < 0.05


def test_scale_factor_columns_predict_the_mechanization_error() -> None:
    """Scale-factor errors (21 states) on a straight drive: expm(F T) dx0 again."""
    from coopproc.ins.errorstate import SA, SG

    s = straight_imu(LAT, LON, H, 15.0, 20.0)
    dx0 = np.zeros(21)
    dx0[SA] = [2e-3, -3e-3, 1e-3]
    dx0[SG] = [0.05, -0.04, 0.03]  # large: the body rates are only earth + transport rate
    truth = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    ins = mechanize(s.time_s, s.nav0, s.dtheta * (1 + dx0[SG]), s.dvel * (1 + dx0[SA]))
    f = f_matrix(s.nav0, s.dvel[0] / DT, s.dtheta[0] / DT, 1e9, 21)
    k = 4000
    predicted = (expm(f * s.time_s[k]) @ dx0)[:9]
    actual = nav_error(ins.nav[k], truth.nav[k])
    scale = np.abs(predicted) + np.array([1e-3] * 3 + [1e-4] * 3 + [1e-7] * 3)
    assert np.abs(actual - predicted) / scale == pytest.approx(np.zeros(9), abs=0.02)
    assert abs(actual[2]) > 1.0  # the vertical accelerometer scale error is visible


def test_levelled_start_correlates_tilt_with_the_accelerometer_bias() -> None:
    """Levelling at rest with a biased accelerometer tilts the frame by ba / g: the P0 of
    level_correlated explains that tilt (the conditional tilt error given the bias is the
    noise part only), the plain diagonal P0 does not."""
    from coopproc.ins.align import level
    from coopproc.ins.earth import normal_gravity
    from coopproc.ins.errorstate import ErrorStateEkf, level_correlated, nav_error
    from coopproc.ins.mechanize import make_nav
    from coopproc.ins.models import GRADES
    from coopproc.ins.quat import euler_to_quat, quat_to_dcm

    fig = GRADES["industrial"]
    lat, yaw = np.radians(35.0), 0.6
    g = normal_gravity(lat, 0.0)
    c = quat_to_dcm(euler_to_quat(0.01, -0.02, yaw))
    ba = np.array([4e-3, -7e-3, 2e-3]) * 9.80665  # 4, -7, 2 mg: turn-on size
    roll, pitch = level(c.T @ np.array([0.0, 0.0, g]) + ba)
    true = make_nav(lat, 0.1, 0.0, np.zeros(3), 0.01, -0.02, yaw)
    ins = make_nav(lat, 0.1, 0.0, np.zeros(3), roll, pitch, yaw)
    psi = nav_error(ins, true)[6:9]
    sig_level = np.hypot(fig.accel_bias0_mps2, 1e-5) / g
    ekf = ErrorStateEkf.start(fig, np.ones(3), np.ones(3), np.array([sig_level, sig_level, 0.1]))
    p = level_correlated(ekf.p, quat_to_dcm(ins[6:10]), g)
    assert np.allclose(p, p.T) and np.all(np.linalg.eigvalsh(p) > -1e-18)
    # the tilt predicted from the bias by P0's regression, psi_hat = P_psi,ba P_ba^-1 ba
    idx = [6, 7]
    gain = p[np.ix_(idx, [12, 13, 14])] @ np.linalg.inv(p[12:15, 12:15])
    assert np.allclose(gain @ ba, psi[:2], atol=2e-5), (gain @ ba, psi[:2])
    assert np.hypot(*psi[:2]) > 5e-4  # the tilt is real (0.04 deg), not noise
    plain = ekf.p[np.ix_(idx, [12, 13, 14])]
    assert np.allclose(plain, 0.0)  # what the diagonal P0 says: no relation
