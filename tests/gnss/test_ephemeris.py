"""Broadcast ephemerides (IS-GPS-200): a known answer, velocity and clock against finite
differences, validity windows, record selection and the Sagnac rotation."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.gnss.ephemeris import (
    F_REL,
    OMEGA_E_DOT,
    GpsEphemerides,
    rotate_to_reception,
    satellite_states,
)

WEEK = 910
TOE = WEEK * 604800.0 + 410400.0


def example(**over: float) -> GpsEphemerides:
    """The worked example of GPS week 910 (toe 410400 s) whose ECEF position at
    t = 403272.93 s is -5.67841101e6, -2.49239629e7, 7.05651887e6 m: the textbook case
    used by georinex's tests/test_kepler.py (scivision/georinex), given there to 9
    significant digits (i.e. to a few metres). Computed independently of coopproc."""
    v = {
        "sqrt_a": 5.15353571e3,
        "e": 4.27323824e-3,
        "i0": 0.97477102,
        "omega0": 2.29116688,
        "omega": -0.88396725,
        "m0": 2.24295542,
        "delta_n": 4.3123e-9,
        "idot": -4.23946e-10,
        "omega_dot": -8.025691e-9,
        "cuc": -6.60121440e-6,
        "cus": 5.31412661e-6,
        "crc": 282.28125,
        "crs": -132.71875,
        "cic": 9.8720193e-8,
        "cis": -3.9115548e-8,
        "af0": 0.0,
        "af1": 0.0,
        "af2": 0.0,
        "tgd": 0.0,
    }
    v.update(over)
    one = {k: np.array([x]) for k, x in v.items()}
    return GpsEphemerides(
        prn=np.array([5]),
        toc_gpst_s=np.array([TOE]),
        toe_gpst_s=np.array([TOE]),
        iode=np.array([1]),
        week=np.array([WEEK]),
        health=np.array([0]),
        fit_interval_h=np.array([4.0]),
        **one,
    )


def test_known_answer_textbook_example() -> None:
    t = WEEK * 604800.0 + 4.03272930e5
    s = satellite_states(example(), np.array([5]), np.array([t]))
    expected = np.array([-5.67841101e6, -2.49239629e7, 7.05651887e6])
    assert s.valid[0]
    # the reference has 9 significant digits: 0.5 m on x and z, 5 m on y
    np.testing.assert_allclose(s.pos_ecef_m[0], expected, atol=1.0)
    # a wrong earth-rotation term (toe not taken off) would be kilometres away
    assert np.linalg.norm(s.pos_ecef_m[0] - expected) < 1.0


def test_velocity_and_clock_drift_match_finite_differences() -> None:
    eph = example(af0=1e-4, af1=2e-11, af2=1e-18)
    t = TOE + np.array([-3000.0, 0.0, 1234.5])
    prn = np.full(3, 5)
    s = satellite_states(eph, prn, t)
    h = 0.5
    plus, minus = satellite_states(eph, prn, t + h), satellite_states(eph, prn, t - h)
    np.testing.assert_allclose(
        s.vel_ecef_mps, (plus.pos_ecef_m - minus.pos_ecef_m) / (2 * h), atol=1e-4
    )
    np.testing.assert_allclose(
        s.clock_drift_sps, (plus.clock_s - minus.clock_s) / (2 * h), rtol=1e-6, atol=1e-18
    )
    speed = np.linalg.norm(s.vel_ecef_mps, axis=1)
    assert np.all((speed > 1000) & (speed < 4500))  # GPS in the earth-fixed frame


def test_clock_has_polynomial_and_relativity_and_tgd_apart() -> None:
    eph = example(af0=1e-4, af1=2e-11, af2=0.0, tgd=-5e-9)
    t = np.array([TOE + 600.0])
    s = satellite_states(eph, np.array([5]), t)
    assert s.relativistic_s[0] != 0.0
    assert abs(s.relativistic_s[0]) <= abs(F_REL) * 4.27323824e-3 * 5.15353571e3 + 1e-15
    np.testing.assert_allclose(s.clock_s, 1e-4 + 2e-11 * 600.0 + s.relativistic_s, rtol=1e-12)
    np.testing.assert_allclose(s.clock_l1_s, s.clock_s + 5e-9, rtol=1e-12)


def test_out_of_validity_and_unknown_prn_are_nan_and_flagged() -> None:
    eph = example()
    t = np.array([TOE + 7199.0, TOE + 7201.0, TOE - 7300.0, TOE])
    s = satellite_states(eph, np.array([5, 5, 5, 9]), t)
    assert s.valid.tolist() == [True, False, False, False]
    assert np.isnan(s.pos_ecef_m[1:]).all() and np.isfinite(s.pos_ecef_m[0]).all()
    assert s.record.tolist() == [0, -1, -1, -1]


def test_nearest_healthy_toe_is_used() -> None:
    a, b, c = example(), example(m0=1.0), example(m0=2.0)
    parts = []
    for eph, dt, health in ((a, 0.0, 0), (b, 7200.0, 0), (c, 3600.0, 1)):
        values = {f: getattr(eph, f) for f in eph.__dataclass_fields__}
        values["toe_gpst_s"] = eph.toe_gpst_s + dt
        values["toc_gpst_s"] = eph.toc_gpst_s + dt
        values["health"] = np.array([health])
        parts.append(GpsEphemerides(**values))
    eph = GpsEphemerides.concatenate(parts)
    s = satellite_states(eph, np.full(3, 5), TOE + np.array([1000.0, 3700.0, 6000.0]))
    # the unhealthy record at +1 h is never chosen
    assert s.record.tolist() == [0, 1, 1]


def test_rotation_during_travel() -> None:
    p = np.array([[26_000e3, 0.0, 1e6]])
    r = rotate_to_reception(p, np.array([0.075]))
    angle = OMEGA_E_DOT * 0.075
    assert r[0, 1] == pytest.approx(-26_000e3 * np.sin(angle))
    assert r[0, 2] == p[0, 2]
    assert np.linalg.norm(r) == pytest.approx(np.linalg.norm(p))
