"""The robust factors from the smoothed solution: one iteration of a robust smoother.

Paper 002's IGG-III factor (eq. (18)-(20)) is decided in the forward filter, on the
innovation at the prior: a range that arrives while the filter is uncertain (after a
turn, a gap, or inside a long NLOS run whose first ranges were taken in) is judged against
a prediction that it cannot contradict, and the smoother then takes the forward pass's
factors as they are. A batch factor graph with a robust (Huber) range loss re-weights
every range against the whole trajectory instead (iteratively re-weighted least squares).
:func:`smoothed_gammas` does that once for the EKF: each range's residual against the
smoothed positions of its two ends at its epoch, standardized by its sigma and the MAD
unit-weight sigma of all the ranges' residuals (eq. (20) over the whole session, floored
at ``mad_floor``), gives its IGG-III factor (eq. (18)); the filter and smoother then run
again with those factors fixed (``ekf_forward``'s ``gamma_in``). Observations other than
ranges (leaders' fixes), and ranges whose end has no recorded smoothed state at the
epoch, keep the forward pass's factor.

``[fusion] robust_smoother_iterations`` (1 by default; 0: the forward factors only, as
paper 002 and 003 write it).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from coopproc.estimation.robust import MAD_SCALE, igg3_factor
from coopproc.model import FloatArray
from coopproc.stages.fusion.ekf import OBS_ANCHOR, OBS_RANGE

__all__ = ["smoothed_gammas"]


def _slot_of(
    key: NDArray[np.int64], rec_key: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    at = np.searchsorted(rec_key, key)
    at = np.minimum(at, max(rec_key.shape[0] - 1, 0))
    found = rec_key[at] == key if rec_key.shape[0] else np.zeros(key.shape[0], dtype=bool)
    return at, found


def smoothed_gammas(
    obs: dict[str, np.ndarray],
    rec_ptr: NDArray[np.int64],
    rec_plat: NDArray[np.int64],
    xs: FloatArray,
    n_plat: int,
    dim: int,
    gamma_forward: FloatArray,
    k0: float,
    k1: float,
    mad_floor: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Every observation's robust factor from the smoothed states ``xs`` (R, dim) at the
    recorded slots (module doc); ``gamma_forward`` where the smoothed one cannot be had.

    Also each observation's residual against the smoothed solution (m) and the
    standardized value its factor was taken from (residual / sigma / the MAD sigma), NaN
    where the forward factor stays: the decisions ``range_weights.csv`` shows."""
    ptr = obs["ptr"]
    n_ep = ptr.shape[0] - 1
    epoch = np.repeat(np.arange(n_ep, dtype=np.int64), np.diff(ptr))
    kind = obs["kind"].astype(np.int64)
    a = obs["a"].astype(np.int64)
    b = obs["b"].astype(np.int64)
    rec_epoch = np.repeat(np.arange(n_ep, dtype=np.int64), np.diff(rec_ptr))
    rec_key = rec_epoch * n_plat + rec_plat
    ranged = (kind == OBS_RANGE) | (kind == OBS_ANCHOR)
    at_a, found = _slot_of(epoch * n_plat + np.maximum(a, 0), rec_key)
    at_b, found_b = _slot_of(epoch * n_plat + np.maximum(b, 0), rec_key)
    found &= ranged & ((kind != OBS_RANGE) | found_b)
    offset = obs["anchor_table"][obs["anchor"].astype(np.int64), :dim]
    xa = xs[at_a]
    diff = np.where((kind == OBS_RANGE)[:, None], xa - xs[at_b] - offset, xa - offset)
    rho = np.sqrt(np.maximum(np.sum(diff * diff, axis=1) + obs["dz2"], 1e-12))
    resid_m = obs["z"] - rho
    resid = resid_m / np.sqrt(obs["var"])
    gamma = gamma_forward.copy()
    use = found & np.isfinite(resid)
    standardized = np.full(resid.shape[0], np.nan)
    if np.count_nonzero(use) == 0:
        return gamma, standardized, standardized.copy()
    sigma = max(MAD_SCALE * float(np.median(np.abs(resid[use]))), mad_floor)
    standardized[use] = resid[use] / sigma
    gamma[use] = igg3_factor(standardized[use], k0, k1)
    resid_m[~use] = np.nan
    return gamma, resid_m, standardized
