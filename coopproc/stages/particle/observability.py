"""Observability of single-auxiliary localization, paper 004 eq. (17)-(19).

The linearized system (17) has state [x, y, phi], transition
Phi(t) = [[1, 0, -dL sin phi], [0, 1, dL cos phi], [0, 0, 1]] and one range row per
auxiliary H = [(x - x_j)/d, (y - y_j)/d, 0]. The piece-wise constant system's
observability matrix (18) stacks H(t) Phi(t-1) ... Phi(0); its singular values (19)
say how observable the state is: a zero singular value means a direction of the state
(e.g. a rotation about a fixed auxiliary) that no range can see.

The products of Phi are unit upper-triangular with the same pattern, so
Phi(t-1)...Phi(0) = [[1, 0, a_t], [0, 1, b_t], [0, 0, 1]] with a_t = -sum dL sin phi and
b_t = sum dL cos phi; :func:`observability_matrix` uses these sums (O(rows)).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.locate_result import Observability
from coopproc.estimation.range_model import slant_ranges_units
from coopproc.model import FloatArray

__all__ = ["analyze", "observability_matrix", "transition"]


def transition(delta_l_m: float, phi_rad: float) -> FloatArray:
    """Phi of eq. (17) for one step of length ``delta_l_m`` at azimuth ``phi_rad``."""
    return np.array(
        [
            [1.0, 0.0, -delta_l_m * np.sin(phi_rad)],
            [0.0, 1.0, delta_l_m * np.cos(phi_rad)],
            [0.0, 0.0, 1.0],
        ]
    )


def observability_matrix(
    target_en_m: FloatArray,
    aux_en_m: FloatArray,
    has_range: np.ndarray,
    delta_l_m: FloatArray,
    phi_step_rad: FloatArray,
) -> tuple[FloatArray, np.ndarray]:
    """R_k of eq. (18) and the epoch of each of its rows.

    ``target_en_m`` (E, 2) linearization points, ``aux_en_m`` (E, J, 2),
    ``has_range`` (E, J) bool, ``delta_l_m`` and ``phi_step_rad`` (E - 1,) the length and
    azimuth of each step (eq. (3)). One row per (epoch, auxiliary) with a range.
    """
    n_e = target_en_m.shape[0]
    a = np.zeros(n_e)
    b = np.zeros(n_e)
    a[1:] = np.cumsum(-delta_l_m * np.sin(phi_step_rad))
    b[1:] = np.cumsum(delta_l_m * np.cos(phi_step_rad))
    rel = target_en_m[:, None, :] - aux_en_m  # (E, J, 2)
    _, unit = slant_ranges_units(rel)
    hx, hy = unit[..., 0], unit[..., 1]  # H(t)
    ok = has_range & np.isfinite(hx) & np.isfinite(hy)
    ep, _ = np.nonzero(ok)
    rows = np.column_stack([hx[ok], hy[ok], hx[ok] * a[ep] + hy[ok] * b[ep]])  # H(t) prod Phi
    return rows, ep


def analyze(
    target_en_m: FloatArray,
    aux_en_m: FloatArray,
    has_range: np.ndarray,
    delta_l_m: FloatArray,
    phi_step_rad: FloatArray,
    tol: float,
) -> Observability:
    """Eq. (19) SVD of R_k; observable when sigma_3 / sigma_1 > ``tol``."""
    rows, ep = observability_matrix(target_en_m, aux_en_m, has_range, delta_l_m, phi_step_rad)
    n_e = target_en_m.shape[0]
    if rows.shape[0] == 0:
        return Observability((0.0, 0.0, 0.0), False, None, np.zeros(n_e))
    sv = np.linalg.svd(rows, compute_uv=False)
    sv3 = np.zeros(3)
    sv3[: sv.shape[0]] = sv
    # the same ratio for R_k cut at every epoch: eigenvalues of the cumulative Gram matrix
    gram = np.zeros((n_e, 3, 3))
    np.add.at(gram, ep, rows[:, :, None] * rows[:, None, :])
    gram = np.cumsum(gram, axis=0)
    eig = np.clip(np.linalg.eigvalsh(gram), 0.0, None)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(eig[:, 2] > 0, np.sqrt(eig[:, 0] / eig[:, 2]), 0.0)
    ok = ratio > tol
    observable = bool(sv3[0] > 0 and sv3[2] / sv3[0] > tol)
    start: int | None = None
    if observable:
        bad = np.nonzero(~ok)[0]
        start = int(bad[-1] + 1) if bad.size else 0
        if start >= n_e:
            start = None
    return Observability(
        singular_values=(float(sv3[0]), float(sv3[1]), float(sv3[2])),
        observable=observable,
        observable_from=start,
        ratio_track=ratio,
    )
