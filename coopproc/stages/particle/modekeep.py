"""Keeping a multi-modal cloud's modes alive until the geometry separates them (issue 17).

With one auxiliary the ranges say little about the rotation about it for the first tens
of seconds; a hypothesis that is right but carried by a handful of particles is then
lost to the ant colony moves (a light particle moves to the heaviest particles, which sit
in another mode), to the kernel jitter (drawn from the whole cloud's covariance, centred
towards its mean: between the modes) and to the resampling (a mode of 0.4 % weight keeps
0.4 % of the particles, then none). While :func:`geometry_separates` says no, the AACOPF
(aacopf.py) therefore:

- cancels the moves from one mode to another (:func:`cancel_cross_mode`; the particles
  of no kept mode count as one more);
- draws the jitter of a moved particle from its own mode (:func:`jitter_by_mode`);
- resamples every mode on its own (:func:`resample_by_mode`), each keeping at least
  ``mode_min_particles`` particles that share its weight: the posterior is unchanged,
  only its sampling.

"The geometry separates them" is the paper's observability analysis (eq. (17)-(19)) on
what has been used so far: R_k from the ranges used up to now along the dead-reckoned
path placed by the current estimate, sigma_3 / sigma_1 above ``observability_tol``.
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.locate_result import LocateInputs
from coopproc.model import FloatArray
from coopproc.stages.particle.core import Cloud, kernel_jitter
from coopproc.stages.particle.observability import observability_matrix
from coopproc.stages.particle.params import LocateParams

__all__ = ["cancel_cross_mode", "geometry_separates", "jitter_by_mode", "resample_by_mode"]


def geometry_separates(
    inputs: LocateInputs,
    used: np.ndarray,
    t: int,
    initial_azimuth_rad: float,
    east_m: float,
    north_m: float,
    tol: float,
) -> bool:
    """Eq. (19) on the ranges ``used`` (E, J) up to epoch ``t``: sigma_3 / sigma_1 > tol."""
    inc = inputs.increments
    phi_step = initial_azimuth_rad + (inc.theta_rad[:t] - inc.theta0_rad)
    steps = inc.delta_l_m[:t, None] * np.column_stack([np.cos(phi_step), np.sin(phi_step)])
    path = np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    path += np.array([east_m, north_m]) - path[-1]
    rows, _ = observability_matrix(
        path, inputs.aux_en_m[: t + 1], used[: t + 1], inc.delta_l_m[:t], phi_step
    )
    if rows.shape[0] < 3:
        return False
    eig = np.clip(np.linalg.eigvalsh(rows.T @ rows), 0.0, None)
    return bool(eig[2] > 0 and np.sqrt(eig[0] / eig[2]) > tol)


def cancel_cross_mode(idx: np.ndarray, mode: np.ndarray) -> np.ndarray:
    """``idx`` with every move to another label undone (-1, no mode, counts as one)."""
    cross = mode[idx] != mode
    return np.where(cross, np.arange(idx.shape[0]), idx)


def jitter_by_mode(
    cloud: Cloud,
    w: FloatArray,
    moved: np.ndarray,
    params: LocateParams,
    rng: np.random.Generator,
) -> None:
    """Kernel jitter of the moved particles, each with its own mode's covariance."""
    assert cloud.mode is not None
    for label in np.unique(cloud.mode[moved]):
        members = cloud.mode == label
        kernel_jitter(cloud, w, moved & members, params, rng, members=members)


def resample_by_mode(
    w: FloatArray, mode: np.ndarray, min_particles: int, rng: np.random.Generator
) -> tuple[np.ndarray, FloatArray]:
    """Systematic resampling within each mode: (indices, new weights).

    Mode k of weight W_k gets n_k = max(round(W_k P), min_particles) particles (P the
    cloud size; the heaviest mode gives up the excess), each of weight W_k / n_k; the
    particles of no mode (label -1) count as one more mode. Modes lighter than 1e-12
    keep nothing.
    """
    size = w.shape[0]
    labels, inverse = np.unique(mode, return_inverse=True)
    weight = np.bincount(inverse, w, minlength=labels.shape[0])
    alive = weight > 1e-12 * weight.max()
    count = np.where(alive, np.maximum(np.round(weight * size), min_particles), 0).astype(np.int64)
    count[int(np.argmax(weight))] -= int(count.sum()) - size
    if count.min() < 0:  # more modes than room for the floor: plain shares
        count = np.floor(weight * size).astype(np.int64)
        count[int(np.argmax(weight))] += size - int(count.sum())
    order = np.argsort(inverse, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(inverse, minlength=labels.shape[0]))])
    out_idx = np.empty(size, dtype=np.int64)
    out_w = np.empty(size)
    at = 0
    for k in range(labels.shape[0]):
        n = int(count[k])
        if n == 0:
            continue
        members = order[bounds[k] : bounds[k + 1]]
        wk = w[members] / weight[k]
        cdf = np.cumsum(wk)
        cdf[-1] = 1.0
        pick = np.searchsorted(cdf, (np.arange(n) + rng.random()) / n, side="right")
        out_idx[at : at + n] = members[np.minimum(pick, members.shape[0] - 1)]
        out_w[at : at + n] = weight[k] / n
        at += n
    return out_idx, out_w / out_w.sum()
