"""Known answers of the strapdown mechanization (coopproc.ins.mechanize)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.frames import geodetic2enu
from coopproc.ins.earth import earth_rate_enu, normal_gravity, radii
from coopproc.ins.mechanize import NavSolution, increments_from_rates, make_nav, mechanize
from coopproc.ins.quat import quat_to_dcm
from coopproc.ins.reference import mechanize_reference, normal_gravity_reference
from coopproc.ins.synth import circle_imu, straight_imu

LAT, LON, H = np.radians(48.0), np.radians(11.0), 500.0
DT = 0.005


def _enu(sol: NavSolution) -> np.ndarray:
    llh = np.column_stack([np.degrees(sol.llh[:, 0]), np.degrees(sol.llh[:, 1]), sol.llh[:, 2]])
    return geodetic2enu(llh, (np.degrees(LAT), np.degrees(LON), H))


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


@pytest.mark.parametrize(
    ("lat_deg", "h", "g"),
    [(0.0, 0.0, 9.7803253359), (90.0, 0.0, 9.8321849378), (45.0, 0.0, 9.80619777)],
)
def test_normal_gravity_known_values(lat_deg: float, h: float, g: float) -> None:
    assert normal_gravity(np.radians(lat_deg), h) == pytest.approx(g, abs=1e-8)


def test_normal_gravity_height_gradient_and_reference() -> None:
    lat = np.radians(30.0)
    # free-air gradient about -3.086e-6 s^-2
    grad = normal_gravity(lat, 1000.0) - normal_gravity(lat, 0.0)
    assert grad == pytest.approx(-3.0855e-3, rel=2e-3)
    assert normal_gravity(lat, 800.0) == pytest.approx(
        normal_gravity_reference(lat, 800.0), abs=1e-10
    )


def test_radii_at_equator_and_pole() -> None:
    m0, n0 = radii(0.0)
    assert n0 == pytest.approx(6378137.0)
    assert m0 == pytest.approx(6335439.327, abs=1e-3)
    mp, np_ = radii(np.pi / 2)
    assert mp == pytest.approx(np_) and mp == pytest.approx(6399593.626, abs=1e-3)


def _static(k: int, nav0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    c = quat_to_dcm(nav0[6:10])
    f_b = c.T @ np.array([0.0, 0.0, normal_gravity(LAT, H)])
    w_b = c.T @ earth_rate_enu(LAT)
    return np.arange(k) * DT, np.tile(w_b * DT, (k, 1)), np.tile(f_b * DT, (k, 1))


def test_stationary_perfect_inputs_do_not_drift() -> None:
    nav0 = make_nav(LAT, LON, H, np.zeros(3), 0.05, -0.03, 1.0)
    t, dth, dv = _static(12001, nav0)  # 60 s
    sol = mechanize(t, nav0, dth, dv)
    enu = _enu(sol)
    assert np.abs(enu).max() < 1e-6
    assert np.abs(sol.vel_enu).max() < 1e-9
    assert np.abs(sol.quat - nav0[6:10]).max() < 1e-11


@pytest.mark.parametrize("axis", [0, 1])
def test_stationary_accel_bias_drifts_as_half_b_t2(axis: int) -> None:
    """A horizontal accelerometer bias b (level unit, yaw 0): error 1/2 b t^2 along it."""
    nav0 = make_nav(LAT, LON, H, np.zeros(3), 0.0, 0.0, 0.0)
    t, dth, dv = _static(12001, nav0)
    bias = 1e-3 * 9.80665  # 1 mg
    dv[:, axis] += bias * DT
    enu = _enu(mechanize(t, nav0, dth, dv))
    expected = 0.5 * bias * 60.0**2
    assert enu[-1, axis] == pytest.approx(expected, rel=0.01)
    assert abs(enu[-1, 1 - axis]) < 0.02 * expected


def test_stationary_gyro_bias_drifts_as_g_eps_t3_over_6() -> None:
    """A gyro bias eps about the east axis tilts the unit: north error -g eps t^3 / 6."""
    nav0 = make_nav(LAT, LON, H, np.zeros(3), 0.0, 0.0, 0.0)
    t, dth, dv = _static(12001, nav0)
    eps = np.radians(10.0) / 3600.0  # 10 deg/h about body x = east
    dth[:, 0] += eps * DT
    enu = _enu(mechanize(t, nav0, dth, dv))
    g = normal_gravity(LAT, H)
    # a positive rotation about east tilts up towards north... f^n gains -g*psi_E on north
    assert enu[-1, 1] == pytest.approx(-g * eps * 60.0**3 / 6.0, rel=0.02)


def test_compiled_loop_matches_the_plain_reference() -> None:
    s = circle_imu(LAT, LON, H, 5.0, 0.3, 5.0)
    rng = np.random.default_rng(3)
    dth = s.dtheta + rng.normal(0, 1e-5, s.dtheta.shape)
    dv = s.dvel + rng.normal(0, 1e-4, s.dvel.shape)
    sol = mechanize(s.time_s, s.nav0, dth, dv)
    ref = mechanize_reference(s.time_s, s.nav0, dth, dv)
    scale = np.array([1e7, 1e7, 1, 1, 1, 1, 1, 1, 1, 1])  # rad of lat/lon -> about m
    assert np.abs((sol.nav - ref) * scale).max() < 1e-8


def test_constant_rate_turn_in_place() -> None:
    s = circle_imu(LAT, LON, H, 0.0, 0.5, 60.0, yaw0=0.3)
    sol = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    assert np.abs(_enu(sol)).max() < 1e-6
    assert np.abs(_wrap(sol.euler()[:, 2] - s.yaw)).max() < 1e-9
    assert np.abs(sol.euler()[:, :2]).max() < 1e-9


def test_circle_closed_form_one_lap() -> None:
    """R = 10 m, one lap in 60 s, with earth rate, transport rate and Coriolis."""
    s = circle_imu(LAT, LON, H, 10.0, 2 * np.pi / 60.0, 60.0, yaw0=0.7)
    sol = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    err = _enu(sol) - s.enu_m
    assert np.abs(err[:, :2]).max() < 2e-4
    assert np.abs(err[:, 2]).max() < 1e-3
    assert np.abs(sol.vel_enu - s.vel_enu).max() < 2e-5
    assert np.abs(_wrap(sol.euler()[:, 2] - s.yaw)).max() < 1e-7


def test_circle_without_coning_sculling_would_be_worse() -> None:
    """The known answer is sensitive: dropping the earth-rate terms from the input fails it."""
    s = circle_imu(LAT, LON, H, 10.0, 2 * np.pi / 60.0, 60.0)
    w_ie = earth_rate_enu(LAT)
    dth = s.dtheta.copy()
    dth[:, 2] -= w_ie[2] * DT  # a gyro that misses the vertical earth rate
    err = _enu(mechanize(s.time_s, s.nav0, dth, s.dvel)) - s.enu_m
    assert np.abs(err[:, :2]).max() > 1e-2


def test_straight_east_drive_stays_on_the_parallel() -> None:
    s = straight_imu(LAT, LON, H, 10.0, 120.0)
    sol = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    assert np.abs(sol.llh[:, 0] - LAT).max() * 6.4e6 < 1e-6
    assert np.abs(sol.llh[:, 2] - H).max() < 1e-6
    _, n = radii(LAT)
    along = (sol.llh[-1, 1] - LON) * (n + H) * np.cos(LAT)
    assert along == pytest.approx(1200.0, abs=1e-6)


def test_increments_from_rates() -> None:
    t = np.array([0.0, 0.01, 0.02, 0.035])
    w = np.ones((4, 3))
    dt, dth, dv = increments_from_rates(t, w, 2 * w)
    assert dt == pytest.approx([0.01, 0.01, 0.01, 0.015])
    assert dth[3] == pytest.approx([0.015] * 3) and dv[0] == pytest.approx([0.02] * 3)


def _coning(seconds: float, beta: float, omega: float) -> tuple[np.ndarray, ...]:
    """Classic coning at rest: C_b^n(t) = Rz(W t) Rx(beta) Rz(-W t), whose body rate is
    W (C^T e_z - e_z) (plus the earth rate); exact increments by Gauss-Legendre."""
    from coopproc.ins.quat import euler_to_quat

    def c_of(t: np.ndarray) -> np.ndarray:
        out = []
        for ti in np.ravel(t):
            q = euler_to_quat(0.0, 0.0, omega * ti)
            c = quat_to_dcm(q) @ quat_to_dcm(euler_to_quat(beta, 0.0, 0.0)) @ quat_to_dcm(q).T
            out.append(c)
        return np.array(out).reshape(*np.shape(t), 3, 3)

    k = round(seconds / DT) + 1
    t = np.arange(k) * DT
    gl_x = np.array(
        [-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526]
    )
    gl_w = np.array(
        [0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538]
    )
    nodes = (t - 0.5 * DT)[:, None] + 0.5 * DT * gl_x[None, :]
    c = c_of(nodes)
    ct = np.swapaxes(c, -1, -2)
    ez = np.array([0.0, 0.0, 1.0])
    w_b = omega * (ct @ ez - ez) + ct @ earth_rate_enu(LAT)
    f_b = ct @ np.array([0.0, 0.0, normal_gravity(LAT, H)])
    dth = 0.5 * DT * np.einsum("j,kjc->kc", gl_w, w_b)
    dv = 0.5 * DT * np.einsum("j,kjc->kc", gl_w, f_b)
    return t, dth, dv, c_of(t)


def test_coning_motion_needs_and_gets_the_coning_correction() -> None:
    """5 deg coning at 2 Hz for 10 s: two-sample algorithm < 1e-6 rad; without the coning
    term the classic drift (about 3e-4 rad about z) appears."""
    from coopproc.ins.mechanize import ins_step
    from coopproc.ins.quat import dcm_to_euler

    t, dth, dv, c_true = _coning(10.0, np.radians(5.0), 2 * np.pi * 2.0)
    e0 = dcm_to_euler(c_true[0])
    nav0 = make_nav(LAT, LON, H, np.zeros(3), e0[0], e0[1], e0[2])
    sol = mechanize(t, nav0, dth, dv)

    def att_err(q: np.ndarray, c: np.ndarray) -> float:
        d = quat_to_dcm(q) @ c.T
        return float(np.linalg.norm([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]) / 2)

    assert att_err(sol.quat[-1], c_true[-1]) < 1e-6
    assert np.abs(sol.vel_enu).max() < 1e-5  # rotation (2nd order) and sculling terms
    nav = nav0.copy()
    zero = np.zeros(3)
    for i in range(1, len(t)):
        ins_step(nav, zero, zero, dth[i], dv[i], DT)  # no coning/sculling history
    assert att_err(nav[6:10], c_true[-1]) > 1e-4


def test_rates_form_equals_increments_form() -> None:
    s = circle_imu(LAT, LON, H, 10.0, 2 * np.pi / 60.0, 10.0)
    gyro, accel = s.dtheta / DT, s.dvel / DT
    _, dth, dv = increments_from_rates(s.time_s, gyro, accel)
    a = mechanize(s.time_s, s.nav0, dth, dv)
    b = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    assert np.abs(a.nav - b.nav).max() < 1e-12
