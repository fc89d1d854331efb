"""Known-answer tests of the distance increments (paper 000 eq. (1), (7)) and the DI smoothing
filter (eq. (4)-(6))."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.configtools import from_table
from coopproc.errors import ConfigError
from coopproc.stages.ranging.di import (
    DISmoothingParams,
    anchored_increments,
    cp_noise_var,
    di_literal,
    di_variance,
    range_increments,
    smooth_di,
)


def test_eq1_literal_known_answer() -> None:
    # platform 1 moves 3-4-5 (5 m), platform 2 moves 1 m: eq. (1) gives 5 - 1 = 4
    p1 = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])
    p2 = np.array([[10.0, 0.0, 0.0], [10.0, 1.0, 0.0]])
    out = di_literal(p1, p2)
    assert np.isnan(out[0])
    assert out[1] == pytest.approx(4.0)


def test_range_increment_known_answer() -> None:
    p1 = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    p2 = np.array([[3.0, 4.0, 0.0], [6.0, 8.0, 0.0]])  # distance 5 -> 10
    out = range_increments(p1, p2)
    assert out[1] == pytest.approx(5.0)


def test_literal_eq1_differs_from_range_change_off_axis() -> None:
    # side by side, 10 m apart, both driving north at 0.5 and 0.4 m/s: the distance
    # barely changes, eq. (1) as printed returns the speed difference
    t = np.arange(0.0, 11.0)
    p1 = np.column_stack([np.zeros_like(t), 0.5 * t, np.zeros_like(t)])
    p2 = np.column_stack([np.full_like(t, 10.0), 0.4 * t, np.zeros_like(t)])
    literal = di_literal(p1, p2)[1:]
    change = range_increments(p1, p2)[1:]
    assert literal == pytest.approx(np.full(10, 0.1))
    true = np.diff(np.hypot(10.0, 0.1 * t))
    assert change == pytest.approx(true)
    assert np.max(np.abs(change)) < 0.01


def test_eq7_variance_known_answer() -> None:
    t = np.array([0.0, 1.0, 1.5, 1.5])
    lin = di_variance(t, 0.02, 0.01, "linear")
    assert np.isnan(lin[0])
    assert lin[1] == pytest.approx(0.02**2 + 0.01**2)
    assert lin[2] == pytest.approx((0.02 * 0.5) ** 2 + (0.01 * 0.5) ** 2)
    assert lin[3] == pytest.approx(1e-8)  # two ranges at one time: floored
    sq = di_variance(t, 0.02, 0.01, "sqrt")
    assert sq[1] == pytest.approx(lin[1])
    assert sq[2] == pytest.approx((0.02**2 + 0.01**2) * 0.5)


def test_anchored_increments_remove_accumulated_drift() -> None:
    t = np.arange(0.0, 61.0)
    heading = 0.05 * t
    truth1 = np.column_stack([5 * np.cos(heading), 5 * np.sin(heading), 0 * t])
    truth2 = np.column_stack([-5 * np.cos(heading), -5 * np.sin(heading), 0 * t])
    drift = np.column_stack([0.05 * t, 0.03 * t, 0 * t])  # 3 m after a minute
    nav1 = truth1 + drift
    true = range_increments(truth1, truth2)
    plain = range_increments(nav1, truth2)
    anchored = anchored_increments(truth1, truth2, nav1, truth2)

    def rms(x: np.ndarray, sl: slice) -> float:
        return float(np.sqrt(np.nanmean((x[sl] - true[sl]) ** 2)))

    late, early = slice(41, None), slice(1, 21)
    # the plain DI error grows with the accumulated drift; the anchored one does not
    assert rms(plain, late) > 2.0 * rms(plain, early)
    assert rms(anchored, late) < 1.2 * rms(anchored, early)
    assert rms(anchored, late) < 0.5 * rms(plain, late)
    # without drift and with the bases equal to nav, anchored == plain
    assert anchored_increments(nav1, truth2, nav1, truth2)[1:] == pytest.approx(plain[1:])


def test_cp_noise_var_is_robust() -> None:
    rng = np.random.default_rng(1)
    dr = np.zeros(2001)
    cp = rng.normal(0.0, 0.01, 2001)
    cp[::50] += 1.0  # jumps
    assert np.sqrt(cp_noise_var(dr, cp)) == pytest.approx(0.01, rel=0.1)


def test_smoothing_first_step_hand_computed() -> None:
    # eq. (4): I^- = DR + s = 0.10, P^-_II = P_ss + Q_I; CP observation 0.11
    t = np.array([0.0, 1.0])
    dr = np.array([np.nan, 0.10])
    cp = np.array([np.nan, 0.11])
    var = np.array([np.nan, 1e-4])
    params = DISmoothingParams(cp_sigma_scale=1.0, deviation_rw=0.0)
    out = smooth_di(t, dr, cp, var, params)
    # R = max(var, MAD variance of a single sample = 0) = 1e-4; P_ss0 = var = 1e-4
    p_ss, q_i, r = 1e-4, 1e-4, 1e-4
    p_ii = p_ss + q_i
    s_var = p_ii + r
    v = 0.11 - 0.10
    assert out.di_m[1] == pytest.approx(0.10 + p_ii / s_var * v)
    assert out.deviation_m[1] == pytest.approx(p_ss / s_var * v)
    assert out.var_m2[1] == pytest.approx(p_ii - p_ii**2 / s_var)
    assert out.jump[1] == 0


def test_smoothing_gates_cp_jumps() -> None:
    n = 200
    t = np.arange(float(n))
    true = 0.05 * np.sin(t / 10.0)
    rng = np.random.default_rng(2)
    dr = true + 0.01 + rng.normal(0, 0.002, n)  # biased DR DI
    cp = true + rng.normal(0, 0.004, n)
    cp[100] += 0.5  # a cooperative-positioning jump
    dr[0] = cp[0] = np.nan
    var = di_variance(t, 0.003, 0.003)
    out = smooth_di(t, dr, cp, var, DISmoothingParams(deviation_rw=1e-3))
    assert out.jump[100] == 1
    assert out.jump.sum() <= 3
    # the jump epoch follows DR DI plus the learned deviation (~ -0.01)
    assert out.di_m[100] == pytest.approx(dr[100] + out.deviation_m[100])
    assert out.deviation_m[150:].mean() == pytest.approx(-0.01, abs=0.003)
    err_smoothed = np.sqrt(np.mean((out.di_m[50:] - true[50:]) ** 2))
    err_dr = np.sqrt(np.mean((dr[50:] - true[50:]) ** 2))
    assert err_smoothed < 0.5 * err_dr


def test_params_from_toml_and_bad_values() -> None:
    p = from_table(DISmoothingParams, {"gate_sigma": 4, "dr_base": "nav"}, "[ranging.di]")
    assert p.gate_sigma == 4.0 and p.dr_base == "nav"
    with pytest.raises(ConfigError, match="did you mean 'gate_sigma'"):
        from_table(DISmoothingParams, {"gate_sigm": 4}, "[ranging.di]")
    with pytest.raises(ConfigError, match="gate_sigma must be > 0"):
        from_table(DISmoothingParams, {"gate_sigma": 0}, "[ranging.di]")
