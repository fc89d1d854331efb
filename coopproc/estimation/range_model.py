"""The range measurement model, written once (issue 34 part 1).

Every estimator that predicts a UWB range takes it from here: the cooperative EKF and its
refit (paper 002 eq. (9)-(10), (14)), the anchors' least squares and range filters
(paper 003), the odometer + UWB filter, the tightly coupled GNSS/INS filters, the INS
range update, the particle filters (paper 004 eq. (17)) and the frame check. The model is

    h(p_a, p_b) = sqrt(|p_a + m_a - p_b - m_b|^2 + dz^2) + b

with ``diff = p_a + m_a - p_b - m_b`` the estimated components (2 in the plane, 3 in
space), ``dz2`` the squared known out-of-plane difference (a plane filter's heights, 0 in
space), ``m`` the antennas' offsets (mounts, or an anchor's position for a fixed end) and
``b`` an optional range-bias state (d h / d b = 1). Its Jacobian is the unit vector
``u = diff / rho``: d h / d p_a = u, d h / d p_b = -u. An antenna on a body with attitude
C_b^n and lever arm l (``cl = C_b^n l``) adds the attitude column u^T [cl x] = (u x cl)^T
for the error-state convention C = (I - [phi x]) C_hat of :mod:`coopproc.ins`
(:func:`lever_arm_row`).

The squared range is summed as ``dz2`` first, then the components in axis order, and
floored at ``RANGE_FLOOR_M ** 2`` so that coincident ends keep a finite unit vector; the
compiled scalar forms (:func:`slant_range`, :func:`range_unit`) and the numpy form over arrays
(:func:`slant_ranges`, :func:`slant_ranges_units`) give the same bits. Value and Jacobian
are tested against finite differences in ``tests/estimation/test_range_model.py``, and
``tests/test_layout.py`` keeps other range formulas out of the estimators.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = [
    "RANGE_FLOOR_M",
    "lever_arm_row",
    "range_unit",
    "slant_range",
    "slant_ranges",
    "slant_ranges_units",
]

#: Smallest modelled range (m): below it the unit vector would be undefined.
RANGE_FLOOR_M = 1e-6
_FLOOR_SQ = RANGE_FLOOR_M * RANGE_FLOOR_M


@numba.njit(cache=True)
def slant_range(diff: FloatArray, dz2: float) -> float:
    """rho = sqrt(dz2 + |diff|^2), floored at :data:`RANGE_FLOOR_M` (compiled)."""
    sq = dz2
    for i in range(diff.shape[0]):
        sq += diff[i] * diff[i]
    return np.sqrt(max(sq, _FLOOR_SQ))


@numba.njit(cache=True)
def range_unit(diff: FloatArray, dz2: float, unit: FloatArray) -> float:
    """:func:`slant_range` and, written to ``unit``, d rho / d diff = diff / rho.
    ``unit`` may be ``diff`` itself (updated in place)."""
    rho = slant_range(diff, dz2)
    for i in range(diff.shape[0]):
        unit[i] = diff[i] / rho
    return rho


@numba.njit(cache=True)
def lever_arm_row(unit: FloatArray, cl: FloatArray, out: FloatArray) -> None:
    """d rho / d phi = (u x cl)^T, written to ``out`` (3): the attitude-error column of a
    range from an antenna at p + C_b^n l, with cl = C_b^n l and C = (I - [phi x]) C_hat."""
    out[0] = unit[1] * cl[2] - unit[2] * cl[1]
    out[1] = unit[2] * cl[0] - unit[0] * cl[2]
    out[2] = unit[0] * cl[1] - unit[1] * cl[0]


def _squared(diff: FloatArray, dz2: FloatArray | float) -> FloatArray:
    sq = np.zeros(diff.shape[:-1]) + dz2
    for i in range(diff.shape[-1]):
        sq = sq + diff[..., i] * diff[..., i]
    return np.asarray(np.maximum(sq, _FLOOR_SQ), dtype=np.float64)


def slant_ranges(diff: FloatArray, dz2: FloatArray | float = 0.0) -> FloatArray:
    """rho over arrays: ``diff`` (..., k) components, ``dz2`` broadcast to (...)."""
    return np.asarray(np.sqrt(_squared(np.asarray(diff, dtype=np.float64), dz2)))


def slant_ranges_units(
    diff: FloatArray, dz2: FloatArray | float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """(rho (...), unit vectors (..., k) = d rho / d diff) over arrays."""
    diff = np.asarray(diff, dtype=np.float64)
    rho = slant_ranges(diff, dz2)
    return rho, diff / rho[..., None]
