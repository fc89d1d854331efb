"""The standard particle filter baseline of paper 004 (section 5.1 (3), 5.2).

Identical inputs to the AACOPF: the same ring initialization, eq. (3) propagation and
Gaussian range likelihood over every auxiliary (no rejection), then systematic
resampling at every epoch (sampling importance resampling).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.locate_result import LocateInputs, Track
from coopproc.model import FloatArray
from coopproc.stages.particle.core import TrackBuilder, init_cloud, propagate, update_weights
from coopproc.stages.particle.kernels import systematic_indices
from coopproc.stages.particle.modes import find_modes
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.progress import ProgressFn

__all__ = ["first_copies", "run_pf", "systematic_resample"]


def systematic_resample(w: FloatArray, u: float) -> np.ndarray:
    """Indices drawn by systematic resampling: one offset ``u`` in [0, 1), P strata."""
    cdf = np.cumsum(w)
    cdf[-1] = 1.0
    return np.asarray(systematic_indices(cdf, float(u)), dtype=np.int64)


def first_copies(idx: np.ndarray) -> np.ndarray:
    """True at the first occurrence of each index in ``idx`` (sorted, as systematic
    resampling gives them)."""
    first = np.ones(idx.shape[0], dtype=bool)
    first[1:] = idx[1:] != idx[:-1]
    return first


def run_pf(
    inputs: LocateInputs, params: LocateParams, seed: int, progress: ProgressFn | None = None
) -> Track:
    """Run the standard PF over all epochs of ``inputs``; returns its track."""
    rng = np.random.default_rng(seed)
    cloud = init_cloud(inputs, params, rng)
    builder = TrackBuilder("pf", inputs, params, rng)
    n_e = inputs.n_epochs
    for t in range(n_e):
        if t > 0:
            propagate(cloud, inputs, t - 1, params, rng)
        w = update_weights(cloud, inputs, t, params)
        builder.record(t, cloud, w)
        if progress is not None:
            progress("pf", t + 1, n_e)
        if t == n_e - 1:  # the modes of the final estimate (before its resampling)
            final = find_modes(
                cloud.east, cloud.north, cloud.phi, w, params.mode_cell_m, params.mode_az_deg
            )
        idx = systematic_resample(w, float(rng.random()))
        cloud.take(idx)
        cloud.log_w = np.full(cloud.size, -np.log(cloud.size))
    return builder.build(modes=final.modes)
