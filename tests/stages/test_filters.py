"""Known answers for the shared Kalman / robust / smoother building blocks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coopproc.estimation.kalman import kf_predict, kf_update, rts_step
from coopproc.estimation.linalg import cholesky_solve_nb
from coopproc.estimation.robust import (
    GAMMA_REJECT,
    igg3_factor,
    igg3_scalar,
    mad_sigma,
    mad_sigma_nb,
    robust_factors,
)
from coopproc.stages.fusion.ekf import OBS_ANCHOR, OBS_RANGE, ekf_forward
from coopproc.stages.fusion.ekf_update import _observe
from coopproc.stages.fusion.kernel_types import (
    Navigation,
    Observations,
    Process,
    Reads,
    Robust,
    Slots,
)


@pytest.mark.parametrize(("k0", "k1"), [(3.0, 4.0), (2.5, 4.5), (3.5, 3.8)])
def test_igg3_known_points(k0: float, k1: float) -> None:
    mid = 0.5 * (k0 + k1)
    expected_mid = (k0 / mid) * 0.25  # ((k1 - mid) / (k1 - k0))^2 = 1/4
    values = igg3_factor(np.array([0.0, k0, -k0, mid, -mid, k1, k1 + 0.1, 50.0]), k0, k1)
    assert values[:3] == pytest.approx([1.0, 1.0, 1.0])
    assert values[3] == pytest.approx(expected_mid, rel=1e-12)
    assert values[4] == pytest.approx(expected_mid, rel=1e-12)
    assert values[5:] == pytest.approx([GAMMA_REJECT] * 3, rel=1e-9)
    for s, want in zip(
        [k0, mid, k1, 10.0], [1.0, expected_mid, GAMMA_REJECT, GAMMA_REJECT], strict=True
    ):
        assert igg3_scalar(s, k0, k1) == pytest.approx(want, rel=1e-12)


def test_igg3_default_midpoint_value() -> None:
    # k0 = 3, k1 = 4, s = 3.5: (3 / 3.5) * (0.5)^2 = 0.2142857...
    assert float(igg3_factor(3.5, 3.0, 4.0)) == pytest.approx(0.21428571428571427)


def test_mad_sigma_known_answer() -> None:
    v = np.array([1.0, -2.0, 3.0, 0.5])
    d = np.array([1.0, 4.0, 9.0, 1.0])
    # |v| / sqrt(d) = 1, 1, 1, 0.5 -> median 1 -> 1.4826
    assert mad_sigma(v, d) == pytest.approx(1.4826)
    assert mad_sigma_nb(v, d, 0.0) == pytest.approx(1.4826)
    assert mad_sigma(0.1 * v, d, floor=1.0) == 1.0
    assert mad_sigma(np.empty(0), np.empty(0), floor=1.0) == 1.0


def test_robust_factors_reject_one_outlier() -> None:
    v = np.array([0.1, -0.05, 0.08, 2.0])
    d = np.full(4, 0.15**2)
    gamma = robust_factors(v, d, 3.0, 4.0)
    assert gamma[:3] == pytest.approx([1.0, 1.0, 1.0])
    assert gamma[3] == pytest.approx(GAMMA_REJECT)


def test_kf_predict_and_update_scalar_known_answer() -> None:
    x, c = kf_predict(
        np.array([1.0]), np.array([[2.0]]), np.eye(1), np.array([[1.0]]), np.array([0.5])
    )
    assert x == pytest.approx([1.5]) and c == pytest.approx(np.array([[3.0]]))
    # z = 3.0, H = 1, R = 1: gain 3/4, x = 1.5 + 0.75 * 1.5, C = 3/4
    x2, c2 = kf_update(x, c, np.array([1.5]), np.eye(1), np.array([1.0]))
    assert x2 == pytest.approx([2.625]) and c2 == pytest.approx(np.array([[0.75]]))
    # gamma = 0.5 doubles R: gain 3/5
    x3, c3 = kf_update(x, c, np.array([1.5]), np.eye(1), np.array([1.0]), np.array([0.5]))
    assert x3 == pytest.approx([1.5 + 0.6 * 1.5]) and c3 == pytest.approx(np.array([[1.2]]))


def test_rts_step_hand_computed() -> None:
    # x_f = 1, C_f = 2; prediction X- = 1, C- = 3 (Q = 1); smoothed next X = 2.5, C = 1.5:
    # A = 2/3, x_s = 1 + 2/3 * 1.5 = 2, C_s = 2 + 4/9 * (1.5 - 3) = 4/3
    x_s, c_s = rts_step(
        np.array([1.0]), np.array([[2.0]]), np.array([1.0]), np.array([[3.0]]),
        np.array([2.5]), np.array([[1.5]]), np.eye(1),
    )  # fmt: skip
    assert x_s == pytest.approx([2.0]) and c_s == pytest.approx(np.array([[4.0 / 3.0]]))


def test_cholesky_solve_matches_numpy() -> None:
    rng = np.random.default_rng(3)
    m = rng.normal(size=(7, 7))
    a = m @ m.T + 7 * np.eye(7)
    b = rng.normal(size=(7, 3))
    assert cholesky_solve_nb(a, b) == pytest.approx(np.linalg.solve(a, b), rel=1e-10)


def _range(x: np.ndarray, kind: int, anchor: np.ndarray, dz2: float, dim: int) -> float:
    other = x[dim : 2 * dim] + anchor[:dim] if kind == OBS_RANGE else anchor[:dim]
    diff = x[:dim] - other
    return float(np.sqrt(diff @ diff + dz2))


@pytest.mark.parametrize(
    ("kind", "dim", "dz2"),
    [(OBS_RANGE, 2, 0.49), (OBS_RANGE, 3, 0.0), (OBS_ANCHOR, 2, 1.0), (OBS_ANCHOR, 3, 0.0)],
)
def test_range_jacobian_matches_finite_differences(kind: int, dim: int, dz2: float) -> None:
    rng = np.random.default_rng(kind * 10 + dim)
    x = rng.normal(0, 10, 2 * dim)
    anchor = rng.normal(0, 10, 3)
    idx = np.zeros(2 * dim, dtype=np.int64)
    val = np.zeros(2 * dim)
    pred, count = _observe(x, kind, 0, 1, anchor, dz2, dim, idx, val)
    assert pred == pytest.approx(_range(x, kind, anchor, dz2, dim), rel=1e-12)
    jac = np.zeros(2 * dim)
    jac[idx[:count]] = val[:count]
    step = 1e-6
    fd = np.array(
        [
            (
                _range(x + step * e, kind, anchor, dz2, dim)
                - _range(x - step * e, kind, anchor, dz2, dim)
            )
            / (2 * step)
            for e in np.eye(2 * dim)
        ]
    )
    assert jac == pytest.approx(fd, abs=1e-8)
    assert count == (2 * dim if kind == OBS_RANGE else dim)


@pytest.mark.slow
def test_compiled_epoch_update_equals_batch_ekf_update() -> None:
    # two platforms in 2D, one range between them and one to an anchor, one fix of p0
    x0 = np.array([0.0, 0.0, 10.0, 1.0])
    c0 = np.diag([0.5, 0.4, 1.0, 2.0])
    anchor = np.array([[0, 0, 0], [3.0, 8.0, 0.0], [0, 0, 0]])
    kind = np.array([OBS_RANGE, OBS_ANCHOR, 2], dtype=np.int64)
    a = np.array([0, 1, 0], dtype=np.int64)
    b = np.array([1, -1, 1], dtype=np.int64)
    z = np.array([10.6, 9.5, 0.3])
    r = np.array([0.02, 0.05, 0.01])
    xs, var, gamma, innov, _, cp_x, cp_c, *_ = ekf_forward(
        x0, c0,
        Navigation(np.zeros(1), np.zeros(2), np.zeros((2, 2)), np.array([0, 1, 2])),
        Process.without_dr(np.zeros(2), False, np.zeros(1)),
        Observations(np.array([0, 3], dtype=np.int64), kind, a, b,
                     np.arange(3, dtype=np.int32), anchor, np.zeros(3), z, r),
        2, Robust(False, 3.0, 4.0, 1.0, 0),
        Slots(np.array([0, 2], dtype=np.int64), np.array([0, 1])), 16,
        np.zeros(0, dtype=np.int64), np.zeros(0),
        Reads(np.array([0, 2], dtype=np.int64), np.array([0, 1]), np.zeros(0, np.int64)),
    )  # fmt: skip
    # the checkpoint before epoch 0 is the prior; the recorded slots are both platforms
    assert cp_x[0] == pytest.approx(x0) and cp_c[0] == pytest.approx(c0)
    d01 = x0[:2] - x0[2:]
    rho01 = np.linalg.norm(d01)
    d1a = x0[2:] - anchor[1, :2]
    rho1a = np.linalg.norm(d1a)
    h = np.array(
        [
            [*(d01 / rho01), *(-d01 / rho01)],
            [0, 0, *(d1a / rho1a)],
            [0, 1.0, 0, 0],
        ]
    )
    v = z - np.array([rho01, rho1a, x0[1]])
    x_ref, c_ref = kf_update(x0, c0, v, h, r)
    assert innov == pytest.approx(v)
    assert xs.reshape(-1) == pytest.approx(x_ref, abs=1e-12)
    assert var.reshape(-1) == pytest.approx(np.diag(c_ref), abs=1e-12)
    assert gamma == pytest.approx(np.ones(3))


@settings(max_examples=200, deadline=None)
@given(
    s=st.floats(-50, 50, allow_nan=False),
    t=st.floats(-50, 50, allow_nan=False),
    k0=st.floats(2.5, 3.5),
    k1=st.floats(3.6, 4.5),
)
def test_igg3_invariants(s: float, t: float, k0: float, k1: float) -> None:
    gs, gt = float(igg3_factor(s, k0, k1)), float(igg3_factor(t, k0, k1))
    assert GAMMA_REJECT <= gs <= 1.0
    assert float(igg3_factor(-s, k0, k1)) == gs  # symmetric in the innovation's sign
    if abs(s) <= abs(t):
        assert gs >= gt  # a larger standardized innovation never gets more weight
    assert igg3_scalar(s, k0, k1) == pytest.approx(gs, rel=1e-12)
