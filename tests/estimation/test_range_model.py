"""The range measurement model (coopproc.estimation.range_model, issue 34 part 1): value
and Jacobian against finite differences, the compiled and numpy forms bit for bit, and the
estimators' rows built from it (the cooperative EKF's, the anchors' least squares)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.estimation.range_model import (
    RANGE_FLOOR_M,
    lever_arm_row,
    range_unit,
    slant_range,
    slant_ranges,
    slant_ranges_units,
)
from coopproc.stages.fusion.ekf_update import OBS_ANCHOR, OBS_RANGE, _observe
from coopproc.stages.shared.lsq import _design

STEP = 1e-6


def _cases(dim: int) -> list[tuple[np.ndarray, float]]:
    rng = np.random.default_rng(dim)
    return [(rng.normal(0.0, 20.0, dim), float(rng.uniform(0.0, 9.0))) for _ in range(20)]


@pytest.mark.parametrize("dim", [2, 3])
def test_the_unit_vector_is_the_gradient_of_the_range(dim: int) -> None:
    for diff, dz2 in _cases(dim):
        unit = np.zeros(dim)
        rho = range_unit(diff, dz2, unit)
        assert rho == pytest.approx(np.sqrt(dz2 + diff @ diff), rel=1e-15)
        for i in range(dim):
            e = np.zeros(dim)
            e[i] = STEP
            fd = (slant_range(diff + e, dz2) - slant_range(diff - e, dz2)) / (2 * STEP)
            assert unit[i] == pytest.approx(fd, abs=1e-8)


def test_the_compiled_and_numpy_forms_agree_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    diff = rng.normal(0.0, 30.0, (500, 2))
    dz2 = rng.uniform(0.0, 4.0, 500)
    rho, unit = slant_ranges_units(diff, dz2)
    for k in range(500):
        u = np.zeros(2)
        assert range_unit(diff[k], dz2[k], u) == rho[k]
        assert np.array_equal(u, unit[k])
    assert np.array_equal(slant_ranges(diff, dz2), rho)


def test_coincident_ends_are_floored_and_nan_propagates() -> None:
    unit = np.zeros(3)
    assert range_unit(np.zeros(3), 0.0, unit) == pytest.approx(RANGE_FLOOR_M)
    assert np.all(unit == 0.0)
    assert np.isnan(slant_range(np.array([np.nan, 1.0]), 0.0))
    assert np.isnan(slant_ranges(np.array([[1.0, np.nan, 2.0]]))[0])


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def test_the_lever_arm_column_is_the_attitude_derivative() -> None:
    """An antenna at p + C l with C = (I - [phi x]) C_hat: d rho / d phi = (u x cl)^T."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        diff, cl = rng.normal(0.0, 10.0, 3), rng.normal(0.0, 1.0, 3)
        unit, row = np.zeros(3), np.zeros(3)
        range_unit(diff, 0.0, unit)
        lever_arm_row(unit, cl, row)

        def rho(phi: np.ndarray, diff: np.ndarray = diff, cl: np.ndarray = cl) -> float:
            return float(slant_range(diff + (np.eye(3) - _skew(phi)) @ cl - cl, 0.0))

        for i in range(3):
            e = np.zeros(3)
            e[i] = STEP
            assert row[i] == pytest.approx((rho(e) - rho(-e)) / (2 * STEP), abs=1e-7)


@pytest.mark.parametrize("kind", [OBS_RANGE, OBS_ANCHOR])
def test_the_cooperative_ekf_row_is_the_models_jacobian(kind: int) -> None:
    """_observe's h(X) and sparse row against finite differences over the whole state."""
    dim, n_plat = 2, 3
    rng = np.random.default_rng(kind)
    x = rng.normal(0.0, 15.0, dim * n_plat + 4)  # positions, then DR states
    offset, dz2 = np.array([0.3, -0.2, 1.1]), 0.49
    idx, val = np.zeros(2 * dim, np.int64), np.zeros(2 * dim)

    def h(state: np.ndarray) -> float:
        return float(_observe(state, kind, 2, 0, offset, dz2, dim, idx.copy(), val.copy())[0])

    pred, count = _observe(x, kind, 2, 0, offset, dz2, dim, idx, val)
    assert count == (2 * dim if kind == OBS_RANGE else dim)
    row = np.zeros(x.shape[0])
    row[idx[:count]] = val[:count]
    fd = np.zeros(x.shape[0])
    for i in range(x.shape[0]):
        e = np.zeros(x.shape[0])
        e[i] = STEP
        fd[i] = (h(x + e) - h(x - e)) / (2 * STEP)
    np.testing.assert_allclose(row, fd, atol=1e-8)
    b = x[0:dim] if kind == OBS_RANGE else 0.0
    assert pred == pytest.approx(float(np.sqrt(dz2 + np.sum((x[4:6] - b - offset[:dim]) ** 2))))


def test_the_anchor_least_squares_design_is_the_models_jacobian() -> None:
    rng = np.random.default_rng(11)
    x = rng.normal(0.0, 10.0, (4, 2))
    pos = rng.normal(0.0, 20.0, (4, 5, 3))
    up = rng.normal(1.0, 0.3, 4)
    rho, a = _design(x, pos, up, 2)
    for i in range(2):
        e = np.zeros(2)
        e[i] = STEP
        fd = (_design(x + e, pos, up, 2)[0] - _design(x - e, pos, up, 2)[0]) / (2 * STEP)
        np.testing.assert_allclose(a[..., i], fd, atol=1e-8)
    np.testing.assert_allclose(
        rho,
        np.sqrt(np.sum((x[:, None] - pos[..., :2]) ** 2, -1) + (up[:, None] - pos[..., 2]) ** 2),
    )
