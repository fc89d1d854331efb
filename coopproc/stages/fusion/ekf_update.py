"""The cooperative EKF's measurement update: observation models and one epoch's batch update.

Observation kinds (``obs_kind``; :mod:`coopproc.stages.fusion.ekf` has the whole model):

- ``OBS_RANGE`` (0): range between moving platforms ``a`` and ``b``;
- ``OBS_ANCHOR`` (1): range between moving platform ``a`` and a fixed point;
- ``OBS_POSITION`` (2): coordinate ``b`` (axis) of platform ``a`` (a leader's own fix).

Only the position part of the state (index ``p * dim + axis``) is observed; the DR states
of :mod:`~coopproc.estimation.dr_model` stacked after the positions enter through the
covariance. The epoch's observations are one batch EKF update, eq. (14)-(17), carried out
as scalar updates whose innovations are corrected for the earlier ones' state change.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.estimation.dr_model import pending_gain
from coopproc.estimation.range_model import range_unit
from coopproc.model import FloatArray
from coopproc.stages.fusion.kernel_types import EpochWork, IntArray, Observations

__all__ = [
    "OBS_ANCHOR",
    "OBS_POSITION",
    "OBS_RANGE",
    "epoch_buffers",
    "epoch_innovations",
    "epoch_update",
    "max_epoch_obs",
]

OBS_RANGE = 0
OBS_ANCHOR = 1
OBS_POSITION = 2


@numba.njit(cache=True)
def _observe(
    x: FloatArray,
    kind: int,
    a: int,
    b: int,
    anchor: FloatArray,
    dz2: float,
    dim: int,
    idx: IntArray,
    val: FloatArray,
) -> tuple[float, int]:
    """Predicted observation h(X) and its sparse Jacobian row (indices, values, count)."""
    if kind == OBS_POSITION:
        idx[0] = a * dim + b
        val[0] = 1.0
        return x[a * dim + b], 1
    for ax in range(dim):
        if kind == OBS_RANGE:
            val[ax] = x[a * dim + ax] - x[b * dim + ax] - anchor[ax]
        else:
            val[ax] = x[a * dim + ax] - anchor[ax]
    rho = range_unit(val[:dim], dz2, val[:dim])  # d rho / d x_a = (x_a - x_b) / rho
    count = 0
    for ax in range(dim):
        idx[count] = a * dim + ax
        count += 1
    if kind == OBS_RANGE:
        for ax in range(dim):
            idx[count] = b * dim + ax
            val[count] = -val[ax]
            count += 1
    return rho, count


@numba.njit(cache=True)
def epoch_innovations(
    x: FloatArray,
    c: FloatArray,
    lo: int,
    m: int,
    obs: Observations,
    dim: int,
    work: EpochWork,
) -> None:
    """Innovations at the prior and their variances d = H C H^T + R, eq. (14), (19), of
    observations ``lo:lo + m``, into ``work`` (``v``, ``d`` and the Jacobian rows)."""
    h_idx, h_val, h_cnt, v, d = work.h_idx, work.h_val, work.h_cnt, work.v, work.d
    for j in range(m):
        o = lo + j
        pred, cnt = _observe(
            x, obs.kind[o], obs.a[o], obs.b[o], obs.anchor_tab[obs.anchor[o]], obs.dz2[o],
            dim, h_idx[j], h_val[j],
        )  # fmt: skip
        h_cnt[j] = cnt
        v[j] = obs.z[o] - pred
        hch = 0.0
        for p in range(cnt):
            for s in range(cnt):
                hch += h_val[j, p] * c[h_idx[j, p], h_idx[j, s]] * h_val[j, s]
        d[j] = hch + obs.r_var[o]


@numba.njit(cache=True)
def epoch_update(
    x: FloatArray,
    c: FloatArray,
    lo: int,
    m: int,
    work: EpochWork,
    gamma: FloatArray,
    r_var: FloatArray,
    keep: bool,
    gains: FloatArray,
    y: FloatArray,
    s_out: FloatArray,
    pend: FloatArray,
    dr_idx: IntArray,
    followers: IntArray,
    dim: int,
) -> None:
    """Batch update eq. (15)-(17) of one epoch as corrected scalar updates, in place.

    ``pend``: each platform's pending DR transition (:mod:`~coopproc.estimation.dr_model`,
    "Deferred transitions"; ``dr_idx`` its DR states' index, ``followers`` the platforms
    that have them): the observations read only
    platforms with none (:mod:`~coopproc.stages.fusion.deferred`), C's update is the
    stored covariance's, and a follower with one pending takes the true gain G C h / s.

    With ``keep``, scalar update j's gain C h / s (row j of ``gains``), its corrected
    innovation (``y[j]``) and variance s (``s_out[j]``) are kept for the smoother.
    Callers pass ``keep`` as ``bool(np.bool_(...))``, a run-time bool: a literal ``True`` or
    ``False`` would compile one specialisation per caller (issue 32, the first run).
    """
    h_idx, h_val, h_cnt, v, ph, x_prior = (
        work.h_idx, work.h_val, work.h_cnt, work.v, work.ph, work.x_prior
    )  # fmt: skip
    n = x.shape[0]
    for i in range(n):
        x_prior[i] = x[i]
    for j in range(m):
        o = lo + j
        cnt = h_cnt[j]
        vj = v[j]
        for p in range(cnt):
            vj -= h_val[j, p] * (x[h_idx[j, p]] - x_prior[h_idx[j, p]])
        # C h from C's rows (C is symmetric: the same values as its columns, read
        # contiguously), summed over h's entries in their order
        for i in range(n):
            ph[i] = 0.0
        for p in range(cnt):
            row = c[h_idx[j, p]]
            hv = h_val[j, p]
            for i in range(n):
                ph[i] += row[i] * hv
        s_var = r_var[o] / gamma[o]  # R / gamma, eq. (16)
        for p in range(cnt):
            s_var += h_val[j, p] * ph[h_idx[j, p]]
        for i in range(n):
            x[i] += ph[i] / s_var * vj
        for f in range(followers.shape[0]):
            p = followers[f]
            if pend[p, 0] != 0.0:
                pending_gain(x, ph, p * dim, dr_idx[p], pend[p], vj / s_var)
        # C -= (C h)(C h)^T / s, eq. (17): (ph_i ph_j) / s is the same number for (i, j)
        # and (j, i), so C stays symmetric bit for bit and is never re-symmetrized
        inv_s = 1.0 / s_var
        for i in range(n):
            pi = ph[i]
            row = c[i]
            for jj in range(n):
                row[jj] -= (pi * ph[jj]) * inv_s
        if keep:
            for i in range(n):
                gains[j, i] = ph[i] / s_var
            y[j] = vj
            s_out[j] = s_var


@numba.njit(cache=True)
def max_epoch_obs(obs_ptr: IntArray) -> int:
    """The most observations of any epoch (at least 1, for buffer sizes)."""
    max_m = 1
    for k in range(obs_ptr.shape[0] - 1):
        max_m = max(max_m, obs_ptr[k + 1] - obs_ptr[k])
    return max_m


@numba.njit(cache=True)
def epoch_buffers(max_m: int, dim: int, n: int) -> EpochWork:
    """Work arrays of one epoch for :func:`epoch_innovations` and :func:`epoch_update`:
    Jacobian rows (indices, values, counts), innovations, their variances, C h, the prior."""
    width = 2 * dim
    return EpochWork(
        np.zeros((max_m, width), dtype=np.int64),
        np.zeros((max_m, width)),
        np.zeros(max_m, dtype=np.int64),
        np.zeros(max_m),
        np.zeros(max_m),
        np.zeros(n),
        np.zeros(n),
    )
