"""Known-answer tests of the distance filter (paper 000 eq. (8)) and NLOS detection /
estimation (eq. (9)-(12)), DI and RN modes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from coopproc.stages.ranging.nlos import KernelParams, filter_distance

BASE = KernelParams(
    sigma_m=0.15,
    initial_sigma_m=0.15,
    gamma_sigma=3.0,
    window_s=3.0,
    aligned=True,
    di_accel_sigma=0.5,
    one_shot=False,
    backdate_s=2.0,
    onset_fraction=0.5,
    confirm_fraction=0.5,
    end_confirm_s=1.0,
    end_min_epochs=2,
    adaptive_n=600,
    adaptive_min_n=10,
    min_sigma_m=0.01,
    suspect_epochs=3,
    positive_only=True,
    max_event_s=120.0,
)


@pytest.mark.parametrize("aligned", [True, False])
def test_first_step_matches_matrix_kalman_filter(aligned: bool) -> None:
    # eq. (8): x = [D, I], F = [[1, 1], [0, 1]], H = I, R = diag(sigma^2, R_I), w_D = 0
    t = np.array([0.0, 1.0])
    rng_m = np.array([10.0, 10.2])
    di = np.array([np.nan, 0.1])
    di_var = np.array([np.nan, 1e-4])
    out = filter_distance(t, rng_m, di, di_var, replace(BASE, aligned=aligned))
    q = (0.5 * 1.0 * 1.0) ** 2
    x = np.array([10.0, 0.0])
    p = np.diag([0.15**2, 1.0])
    f = np.array([[1.0, 1.0], [0.0, 1.0]])
    qm = q * np.ones((2, 2)) if aligned else np.diag([0.0, q])
    x = f @ x
    p = f @ p @ f.T + qm
    r = np.diag([0.15**2, 1e-4])
    k = p @ np.linalg.inv(p + r)
    x = x + k @ (np.array([10.2, 0.1]) - x)
    assert out.distance_m[0] == pytest.approx(10.0)
    assert out.distance_m[1] == pytest.approx(x[0], abs=1e-12)
    assert out.nlos_flag.sum() == 0


def _nlos_series(eps: np.ndarray, start: int, n: int = 300, rate_hz: float = 10.0):
    t = np.arange(n) / rate_hz
    rng_m = np.full(n, 20.0)
    rng_m[start : start + eps.shape[0]] += eps
    di = np.zeros(n)
    di[0] = np.nan
    di_var = np.full(n, 1e-10)
    return t, rng_m, di, di_var


def test_detection_running_mean_and_final_estimate() -> None:
    j = np.arange(100)
    eps = 0.6 + 0.1 * np.sin(j)  # every value above gamma_max = 0.45
    t, rng_m, di, var = _nlos_series(eps, 50)
    out = filter_distance(t, rng_m, di, var, BASE)
    # eq. (9): detected at the first NLOS epoch; flagged exactly while it lasts
    assert np.flatnonzero(out.nlos_flag).tolist() == list(range(50, 150))
    assert set(out.event[50:150]) == {0}
    # eq. (10)/(11): D' = 20 exactly, eps_j = L_j - D', running mean over t - t0 < M = 3 s
    steps = out.step_estimate_m[np.isfinite(out.step_estimate_m)]
    assert steps.shape[0] == 30
    assert steps == pytest.approx(np.cumsum(eps[:30]) / np.arange(1, 31), abs=1e-9)
    # eq. (12): held for the rest of the event
    final = eps[:30].mean()
    assert out.nlos_estimate_m[80:150] == pytest.approx(np.full(70, final))
    assert out.nlos_estimate_m[150:].max() == 0.0
    # corrected ranges keep the distance near the truth
    assert np.max(np.abs(out.distance_m - 20.0)) < 0.05


def test_rn_mode_estimates_once() -> None:
    eps = 0.6 + 0.1 * np.sin(np.arange(100))
    t, rng_m, di, var = _nlos_series(eps, 50)
    params = replace(BASE, one_shot=True, backdate_s=0.0, confirm_fraction=0.0)
    out = filter_distance(t, rng_m, di, var, params)
    assert out.nlos_flag[50] == 1
    assert np.isfinite(out.step_estimate_m).sum() == 1
    assert out.nlos_estimate_m[50:140] == pytest.approx(np.full(90, eps[0]))


def test_onset_back_dating() -> None:
    eps = np.full(60, 0.6)
    eps[0] = 0.40  # above onset_fraction * gamma, below gamma: detected one epoch late
    t, rng_m, di, var = _nlos_series(eps, 50)
    out = filter_distance(t, rng_m, di, var, BASE)
    assert out.nlos_flag[50] == 1
    steps = out.step_estimate_m[np.isfinite(out.step_estimate_m)]
    assert steps[0] == pytest.approx(0.40)
    assert steps[-1] == pytest.approx((0.40 + 29 * 0.6) / 30)


def test_suspects_in_a_row_start_an_event() -> None:
    eps = np.full(60, 0.40)  # never beyond gamma_max = 0.45
    t, rng_m, di, var = _nlos_series(eps, 50)
    out = filter_distance(t, rng_m, di, var, BASE)
    assert np.flatnonzero(out.nlos_flag).tolist() == list(range(50, 110))
    assert out.nlos_estimate_m[100] == pytest.approx(0.40)
    off = filter_distance(t, rng_m, di, var, replace(BASE, suspect_epochs=0))
    assert off.nlos_flag.sum() == 0


def test_single_outlier_is_a_false_alarm() -> None:
    eps = np.array([0.9])
    t, rng_m, di, var = _nlos_series(eps, 50)
    out = filter_distance(t, rng_m, di, var, BASE)
    assert out.nlos_flag.sum() == 0
    assert (out.event == -1).all()
    assert np.max(np.abs(out.distance_m - 20.0)) < 1e-6


def test_negative_event_re_anchors_the_distance() -> None:
    t = np.arange(300) / 10.0
    rng_m = np.where(np.arange(300) < 100, 20.0, 19.4)  # the filter had absorbed 0.6 m
    di = np.zeros(300)
    di[0] = np.nan
    out = filter_distance(t, rng_m, di, np.full(300, 1e-10), BASE)
    assert out.nlos_flag.sum() == 0
    assert out.distance_m[100:] == pytest.approx(np.full(200, 19.4), abs=1e-6)


def test_rn_negative_estimate_re_anchors() -> None:
    t = np.arange(300) / 10.0
    rng_m = np.where(np.arange(300) < 100, 20.0, 19.4)
    di = np.zeros(300)
    di[0] = np.nan
    params = replace(BASE, one_shot=True, backdate_s=0.0, confirm_fraction=0.0)
    out = filter_distance(t, rng_m, di, np.full(300, 1e-10), params)
    assert out.nlos_flag.sum() == 0
    assert out.distance_m[100:] == pytest.approx(np.full(200, 19.4), abs=1e-6)


def test_adaptive_sigma_from_innovations() -> None:
    rng = np.random.default_rng(5)
    n = 3000
    t = np.arange(n) * 0.1
    true = 15.0 + 2.0 * np.sin(t / 20.0)
    rng_m = true + rng.normal(0.0, 0.1, n)
    di = np.r_[np.nan, np.diff(true)]
    params = replace(BASE, sigma_m=-1.0, initial_sigma_m=0.3)
    out = filter_distance(t, rng_m, di, np.full(n, 1e-8), params)
    assert np.median(out.sigma_m[600:]) == pytest.approx(0.1, rel=0.15)
    assert out.nlos_flag.mean() < 0.01
    rms_out = np.sqrt(np.mean((out.distance_m[600:] - true[600:]) ** 2))
    assert rms_out < 0.4 * 0.1


def test_the_kernel_settings_are_the_params_by_name() -> None:
    """The compiled loop's FilterSettings are KernelParams' fields of the same names, each
    as the loop's type (one list of the numbers, issue 34)."""
    from coopproc.stages.ranging.nlos import _settings
    from coopproc.stages.ranging.nlos_types import FilterSettings

    given = replace(BASE, adaptive_n=0, end_min_epochs=2.0, window_s=3)  # type: ignore[arg-type]
    settings = _settings(given)
    for name in FilterSettings._fields:
        assert settings._asdict()[name] == getattr(given, name) or name == "adaptive_n"
    assert settings.adaptive_n == 1  # at least one epoch
    assert type(settings.end_min_epochs) is int and type(settings.window_s) is float
    assert type(settings.aligned) is bool
