"""Tightly coupled UWB ranges with a lever arm in the closed loop (coopproc.ins.loop)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.ins.earth import llh_to_ecef
from coopproc.ins.errorstate import POS, ErrorStateEkf, inject_error, nav_error
from coopproc.ins.loop import run_filter
from coopproc.ins.mechanize import mechanize
from coopproc.ins.models import GRADES
from coopproc.ins.synth import circle_imu
from coopproc.ins.updates import antenna_ecef, range_update

LAT, LON, H = np.radians(48.0), np.radians(11.0), 500.0
DT = 0.005
LEVER = np.array([0.2, 0.1, 0.8])
# anchors: ENU offsets (m) from the start, turned into geodetic (small-offset formula)
ANCHORS_ENU = np.array(
    [[-15.0, -5.0, 2.0], [15.0, -5.0, 2.5], [15.0, 25.0, 1.5], [-15.0, 25.0, 3.0]]
)


def _anchor_llh(enu: np.ndarray) -> np.ndarray:
    r = 6.37e6
    return np.array([LAT + enu[1] / r, LON + enu[0] / (r * np.cos(LAT)), H + enu[2]])


@pytest.mark.parametrize("scale_factors", [False, True])
def test_ranges_with_lever_arm_keep_a_consumer_imu_on_the_circle(scale_factors: bool) -> None:
    noise = GRADES["consumer"]
    s = circle_imu(LAT, LON, H, 10.0, 2 * np.pi / 40.0, 80.0)
    truth = mechanize(s.time_s, s.nav0, s.dtheta, s.dvel)
    rng = np.random.default_rng(11)
    bias_g = np.radians([20.0, -30.0, 25.0]) / 3600.0
    bias_a = np.array([1.5e-3, -2e-3, 1e-3]) * 9.80665
    dth = s.dtheta + bias_g * DT + rng.normal(0, noise.arw_rad_rts * np.sqrt(DT), s.dtheta.shape)
    dv = s.dvel + bias_a * DT + rng.normal(0, noise.vrw_mps_rts * np.sqrt(DT), s.dvel.shape)
    anchors = [_anchor_llh(a) for a in ANCHORS_ENU]
    anchors_e = [llh_to_ecef(*a) for a in anchors]
    dx0 = np.zeros(15)
    dx0[POS] = [0.5, -0.4, 0.3]
    dx0[6:9] = np.radians([0.5, -0.5, 3.0])
    nav0 = inject_error(s.nav0, dx0)
    ekf = ErrorStateEkf.start(
        noise, np.full(3, 1.0), np.full(3, 0.1), np.radians([1.0, 1.0, 5.0]), scale_factors
    )
    rejected = []

    def aid(k: int, nav: np.ndarray, w_b: np.ndarray) -> list:
        if k % 20:
            return []
        ant, _, _ = antenna_ecef(truth.nav[k], LEVER)
        out = []
        for j, (a, ae) in enumerate(zip(anchors, anchors_e, strict=True)):
            rho = float(np.linalg.norm(ant - ae)) + rng.normal(0, 0.05)
            if k == 4000 and j == 2:
                rho += 3.0  # NLOS outlier
                rejected.append(k)
            out.append(range_update(nav, a, LEVER, rho, 0.05))
        return out

    sol = run_filter(s.time_s, dth, dv, nav0, ekf, aid, robust=(3.0, 4.5))
    err = np.array([nav_error(sol.nav[k], truth.nav[k]) for k in range(2000, len(s.time_s), 20)])
    horizontal = np.hypot(err[:, 0], err[:, 1])
    assert np.sqrt(np.mean(horizontal**2)) < 0.05  # after 10 s of convergence
    assert np.abs(err[:, 2]).max() < 0.2
    # heading: 3 deg at the start, weakly observable at 0.25 m/s^2 centripetal; it converges
    assert np.degrees(abs(err[-1, 8])) < 1.5
    assert abs(err[-1, 8]) < 0.7 * abs(err[0, 8])
    assert rejected == [4000]
    err_at_outlier = np.hypot(*nav_error(sol.nav[4000], truth.nav[4000])[:2])
    assert err_at_outlier < 0.1
    if scale_factors:
        assert ekf.n == 21
