"""Compiled per-epoch loops of the cooperative EKF and its RTS smoother.

The state is the stacked position of every moving platform, ``dim`` (2 or 3) values per
platform: index ``p * dim + axis``. The transition is the identity plus the platforms'
dead-reckoning increments as control input (F = I, X_k = X_{k-1} + u_k), the process
noise diagonal ``q`` (paper 002 eq. (12)-(13)). Observations of one epoch are processed
as one batch EKF update (eq. (14)-(17)), carried out as scalar updates whose innovations
are corrected for the state change of the earlier ones (exactly the batch update for a
diagonal R), so no matrix is inverted and the cost is O(m n^2) per epoch.

Memory is bounded by design (issue 11): the dead-reckoning increments and process noise
are formed inside the loop from each platform's own navigation samples, interpolated at
the epochs as the loop reaches them (:func:`nav_at`, ``np.interp`` bit for bit: no (P, K)
navigation, no (K, n) arrays), the
states are written only at the *recorded* (epoch, platform) slots the caller asks for
(``rec_ptr``/``rec_plat``, CSR by epoch), and for the smoother only a checkpoint (x, C)
every ``block`` epochs is kept; :mod:`coopproc.stages.fusion.smoother` re-runs each block
from its checkpoint (bit for bit the same arithmetic, with the forward pass's robust
factors) instead of storing K covariances.

Observation kinds (``obs.kind``):

- ``OBS_RANGE`` (0): range between moving platforms ``a`` and ``b``, |X_a - X_b - o| with
  ``o = anchor_tab[obs_anchor]`` the difference of their dead-reckoning motion from the
  epoch time to the range's own time (0 when the range is at the epoch time);
- ``OBS_ANCHOR`` (1): range between moving platform ``a`` and the fixed point ``anchor``
  (the anchor minus a's dead-reckoning motion from the epoch time to the range time),
  also the row ``obs_anchor`` of ``anchor_tab`` (a few anchors, not a point per
  observation: codes are int8/int32, read only here);
- ``OBS_POSITION`` (2): coordinate ``b`` (axis) of platform ``a`` (a leader's own fix).

With ``dim == 2`` the range model (:mod:`coopproc.estimation.range_model`) is
sqrt(dz2 + de^2 + dn^2) where ``dz2`` is the squared height difference taken from the
navigation (or the anchor's height); with ``dim == 3`` ``dz2`` is 0 and the height is
estimated. The kernels' inputs are the typed groups of
:mod:`~coopproc.stages.fusion.kernel_types`.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.estimation.dr_model import DR_STATES, PEND, dr_predict, fold_noise
from coopproc.estimation.robust import MAD_SCALE, igg3_scalar, mad_sigma_nb
from coopproc.model import FloatArray
from coopproc.stages.fusion.copies import copy1, copy2
from coopproc.stages.fusion.deferred import reads_all, touch_all, touch_epoch
from coopproc.stages.fusion.dr_faults import fault_buffers, judge_epoch, leaders, take_jumps
from coopproc.stages.fusion.ekf_update import (
    OBS_ANCHOR,
    OBS_POSITION,
    OBS_RANGE,
    epoch_buffers,
    epoch_innovations,
    epoch_update,
    max_epoch_obs,
)
from coopproc.stages.fusion.kernel_types import (
    IntArray,
    Navigation,
    Observations,
    Process,
    Reads,
    Robust,
    Slots,
)
from coopproc.stages.fusion.mad_window import union_median, window_push
from coopproc.stages.fusion.nav_kernel import nav_at

__all__ = [
    "OBS_ANCHOR",
    "OBS_POSITION",
    "OBS_RANGE",
    "block_size",
    "ekf_forward",
    "epoch_buffers",
    "epoch_innovations",
    "epoch_update",
    "nav_at",
    "time_update",
]

#: Epochs with this many observations or more take eq. (20)'s MAD over their own
#: innovations; fewer are pooled with the last ``mad_window`` ones.
MAD_EPOCH_MIN = 8


def block_size(n_epochs: int) -> int:
    """Epochs between smoother checkpoints: about sqrt(K), so that the checkpoints and one
    block's re-run hold about the same memory (2 sqrt(K) covariances in all)."""
    return max(16, int(np.ceil(np.sqrt(max(n_epochs, 1)))))


@numba.njit(cache=True)
def time_update(
    x: FloatArray,
    c: FloatArray,
    nav_now: FloatArray,
    nav_prev: FloatArray,
    k: int,
    dim: int,
    proc: Process,
    pend: FloatArray,
    jump_k: IntArray,
    jump_p: IntArray,
    jump_var: FloatArray,
    n_jumps: int,
) -> None:
    """Paper 002 eq. (12)-(13): X += u_k, C += Q_k, in place; with DR states
    (:mod:`~coopproc.estimation.dr_model`) X = f(X, u_k) and C = F C F^T + Q_k deferred:
    F multiplied into the follower's pending G (``pend[p]``), the DR states' noise added
    to its pending noise as G^-1 Q G^-T, the positions' to C as it is (G's position
    columns are I's).

    u_k is each platform's dead-reckoning increment ``nav_now[p] - nav_prev[p]`` (its
    navigation at epochs k and k - 1, :func:`nav_at`); the position process noise per
    axis is ``q_coef[p] * dt[k]`` (``q_squared``: ``(q_coef[p] * dt[k]) ** 2``), from
    ``proc`` (:class:`~coopproc.stages.fusion.kernel_types.Process`).
    ``dr_idx[p]``: the index of platform p's heading correction (-1: no DR states, F = I
    for it); ``dr_q[p]``: the heading, heading-rate and scale random walks' variance per
    second, then the position's and the heading's variance per metre travelled (the
    odometer's noise grows with the distance, :mod:`~coopproc.estimation.dr_model`);
    The first ``n_jumps`` of ``jump_k`` (ascending), ``jump_p``, ``jump_var``: a dead
    reckoning's jump, variance added to each horizontal axis of platform ``jump_p[j]``
    at epoch ``jump_k[j]`` (:mod:`~coopproc.stages.fusion.dr_faults`; ``proc``'s own
    after the forward pass).
    """
    q_coef, q_squared, dt, dr_idx, dr_q = (
        proc.q_coef,
        proc.q_squared,
        proc.dt,
        proc.dr_idx,
        proc.dr_q,
    )
    if n_jumps > 0 and jump_k[n_jumps - 1] >= k:
        j = int(np.searchsorted(jump_k[:n_jumps], k))
        while j < n_jumps and jump_k[j] == k:
            for ax in range(min(dim, 2)):
                i = jump_p[j] * dim + ax
                c[i, i] += jump_var[j]
            j += 1
    for p in range(nav_now.shape[0]):
        if q_squared:
            t = q_coef[p] * dt[k]
            qp = t * t
        else:
            qp = q_coef[p] * dt[k]
        e = dr_idx[p]
        if e >= 0:
            i0 = p * dim
            ue = nav_now[p, 0] - nav_prev[p, 0]
            un = nav_now[p, 1] - nav_prev[p, 1]
            dr_predict(x, i0, e, ue, un, dt[k], pend[p])
            for ax in range(2, dim):  # up: the increment as it is
                x[i0 + ax] += nav_now[p, ax] - nav_prev[p, ax]
            travel = np.sqrt(ue * ue + un * un)
            for ax in range(dim):
                c[i0 + ax, i0 + ax] += qp + dr_q[p, DR_STATES] * travel
            fold_noise(
                pend[p], dr_q[p, 0] * dt[k] + dr_q[p, DR_STATES + 1] * travel,
                dr_q[p, 1] * dt[k], dr_q[p, 2] * dt[k],
            )  # fmt: skip
            continue
        for ax in range(dim):
            i = p * dim + ax
            x[i] += nav_now[p, ax] - nav_prev[p, ax]
            c[i, i] += qp


@numba.njit(cache=True)
def ekf_forward(
    x0: FloatArray,
    c0: FloatArray,
    nav: Navigation,
    proc: Process,
    obs: Observations,
    dim: int,
    rob: Robust,
    slots: Slots,
    block: int,
    dr_rec: IntArray,
    gamma_in: FloatArray,
    reads: Reads,
) -> tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
    FloatArray, FloatArray, FloatArray, IntArray, IntArray, FloatArray,
]:  # fmt: skip
    """Forward EKF over K epochs (K = ``proc.dt.shape[0]``; each platform's navigation
    samples ``nav`` as :func:`nav_at` reads them; the inputs' groups are
    :mod:`~coopproc.stages.fusion.kernel_types`'s).

    ``mad_window``: the MAD unit-weight sigma of eq. (20) of an epoch with fewer than
    :data:`MAD_EPOCH_MIN` observations is taken over its innovations together with the last
    ``mad_window`` standardized innovations of earlier epochs (0: the epoch's alone, as
    paper 002 writes it for many satellites per epoch, which larger epochs keep).
    With one range per epoch (staggered UWB polling) the epoch-only MAD is |v| / sqrt(d)
    itself, every standardized innovation is 1 and the robust factor never acts.

    Returns the filtered states and variances at the recorded slots (R, dim) (slot r is
    platform ``slots.plat[r]`` at the epoch whose ``slots.ptr`` range holds r), the robust
    factor of every observation (M,), its innovation at the prior (M,) and that
    innovation's variance H C H^T + R (M,), and the smoother checkpoints: state (B, n) and
    covariance (B, n, n) before epoch ``b * block`` (``block <= 0``: none kept); then the
    DR states (every state after the positions, ``n - P dim``) and their variances at the
    epochs ``dr_rec`` (ascending), (len(dr_rec), n - P dim) each; last, every
    observation's standardized innovation (M,), the value eq. (18) turned into its robust
    factor: v / (sigma sqrt(H C H^T + R)) with eq. (20)'s MAD sigma (without the robust
    factor, or with ``gamma_in``, sigma = 1). ``proc.dr_idx``, ``proc.dr_q``: see
    :func:`time_update` (all -1: the position-only filter). ``gamma_in``: every
    observation's robust factor, given (an iteration of the robust smoother,
    :mod:`~coopproc.stages.fusion.robust_refit`), instead of eq. (18)-(20) at the prior
    (empty: computed here). Then the dead-reckoning jumps given (epoch, platform,
    variance; :mod:`~coopproc.stages.fusion.dr_faults`): ``proc``'s, and with
    ``rob.fault_window > 0`` and the robust factor computed here those the filter found
    (given as process noise with ``rob.fault_apply``, else found only).
    """
    robust, k0, k1, sigma_floor, mad_window, fault_window, fault_apply = rob
    rec_ptr, rec_plat = slots
    n_epochs = proc.dt.shape[0]
    n = x0.shape[0]
    n_obs = obs.z.shape[0]
    n_rec = rec_plat.shape[0]
    xs = np.empty((n_rec, dim))
    var = np.empty((n_rec, dim))
    n_blocks = (n_epochs + block - 1) // block if block > 0 else 0
    cp_x = np.empty((n_blocks, n))
    cp_c = np.empty((n_blocks, n, n))
    gamma = np.ones(n_obs)
    given = gamma_in.shape[0] == n_obs and n_obs > 0
    if given:
        copy1(gamma, gamma_in)
        robust = False
    innov = np.zeros(n_obs)
    innov_var = np.zeros(n_obs)
    std_innov = np.zeros(n_obs)
    x = x0.copy()
    c = c0.copy()
    max_m = max_epoch_obs(obs.ptr)
    work = epoch_buffers(max_m, dim, n)
    v, d = work.v, work.d
    unused = np.zeros((1, 1))
    unused_v = np.zeros(1)
    ring = np.zeros(max(mad_window, 1))
    ring_sorted = np.zeros(max(mad_window, 1) + 1)  # the ring's values but NaN, ascending
    ring_state = np.zeros(4, dtype=np.int64)  # filled, next slot, sorted count, NaN count
    pool = np.zeros(max(mad_window, 1) + max_m)
    ones = np.ones(max(mad_window, 1) + max_m)
    n_plat = nav.ptr.shape[0] - 1
    cursor = np.full(n_plat, -1, dtype=np.int64)
    nav_prev = np.zeros((n_plat, dim))
    nav_now = np.zeros((n_plat, dim))
    pend = np.zeros((n_plat, PEND))  # pending DR transitions (dr_model, "Deferred")
    no_log = np.zeros(0, np.int64)
    no_log_g = np.zeros((0, PEND))
    n_pos = n_plat * dim
    followers = np.flatnonzero(proc.dr_idx >= 0)
    every_next = 0
    dr_x = np.empty((dr_rec.shape[0], n - n_pos))
    dr_var = np.empty((dr_rec.shape[0], n - n_pos))
    dr_next = 0
    faults = fault_buffers(n_plat)
    n_given = proc.jump_k.shape[0]  # given (a refit's): kept, none found
    jump_k = np.zeros(max(n_given, 16), np.int64)
    jump_p = np.zeros(max(n_given, 16), np.int64)
    jump_var = np.zeros(max(n_given, 16))
    jump_k[:n_given] = proc.jump_k
    jump_p[:n_given] = proc.jump_p
    jump_var[:n_given] = proc.jump_var
    n_jumps = n_given
    judge = robust and fault_window > 0.0 and n_given == 0
    fixed = leaders(obs, n_plat)
    scale = np.ones(max_m)
    unit = np.ones(max_m)
    if n_epochs > 0:
        nav_at(nav.t, nav.v, nav.ptr, nav.epochs[0], cursor, nav_prev)
    for k in range(n_epochs):
        if block > 0 and k % block == 0:  # a checkpoint holds the true covariance
            touch_all(c, pend, proc.dr_idx, followers, dim, no_log, no_log_g, 0)
            copy1(cp_x[k // block], x)
            copy2(cp_c[k // block], c)
        if k > 0:
            nav_at(nav.t, nav.v, nav.ptr, nav.epochs[k], cursor, nav_now)
            time_update(
                x, c, nav_now, nav_prev, k, dim, proc, pend, jump_k, jump_p, jump_var,
                n_jumps if fault_apply else 0,
            )  # fmt: skip
            copy2(nav_prev, nav_now)
        lo = obs.ptr[k]
        m = obs.ptr[k + 1] - lo
        dr_now = dr_next < dr_rec.shape[0] and dr_rec[dr_next] == k
        every, every_next = reads_all(reads.every, every_next, k)
        if followers.shape[0] > 0:
            touch_epoch(
                c, pend, proc.dr_idx, followers, dim, obs, lo, m, reads.plat, reads.ptr[k],
                reads.ptr[k + 1], every, no_log, no_log_g, 0,
            )  # fmt: skip
        epoch_innovations(x, c, lo, m, obs, dim, work)
        for j in range(m):
            innov[lo + j] = v[j]
            innov_var[lo + j] = d[j]
            std_innov[lo + j] = v[j] / np.sqrt(d[j])
        if robust and m > 0 and (mad_window <= 0 or m >= MAD_EPOCH_MIN):
            # eq. (20) -> (19) -> (18) over the epoch's own innovations
            sigma = mad_sigma_nb(v[:m], d[:m], sigma_floor)
        elif robust and m > 0:  # too few for a median: the epoch and the recent window
            used = 0
            clean = ring_state[3] == 0
            for j in range(m):
                pool[used] = abs(v[j]) / np.sqrt(d[j])
                clean = clean and not np.isnan(pool[used])
                used += 1
            if clean:  # the median of the kept sorted window and the epoch's values
                median = union_median(ring_sorted, ring_state[2], pool, m)
                sigma = max(MAD_SCALE * median, sigma_floor)
            else:  # a NaN: the partition of the pooled values, as it always was
                for j in range(ring_state[0]):
                    pool[used] = ring[j]
                    used += 1
                sigma = mad_sigma_nb(pool[:used], ones[:used], sigma_floor)
        if robust and m > 0:
            for j in range(m):
                std_innov[lo + j] = v[j] / (sigma * np.sqrt(d[j]))
                gamma[lo + j] = igg3_scalar(std_innov[lo + j], k0, k1)
                if mad_window > 0:
                    window_push(ring, ring_sorted, ring_state, abs(v[j]) / np.sqrt(d[j]))
                unit[j] = np.sqrt(d[j])
                scale[j] = sigma * unit[j]
            if judge and k + 1 < n_epochs:  # a jump is given at the next epoch
                judge_epoch(
                    faults, k, nav.epochs[k], lo, m, obs, work, innov, scale, unit, fixed,
                    fault_window, k0,
                )  # fmt: skip
                jump_k, jump_p, jump_var, n_jumps = take_jumps(
                    faults, k + 1, jump_k, jump_p, jump_var, n_jumps
                )
        epoch_update(
            x, c, lo, m, work, gamma, obs.r_var, bool(np.bool_(False)), unused, unused_v,
            unused_v, pend, proc.dr_idx, followers, dim,
        )  # fmt: skip
        for r in range(rec_ptr[k], rec_ptr[k + 1]):
            p = rec_plat[r]
            for ax in range(dim):
                xs[r, ax] = x[p * dim + ax]
                var[r, ax] = c[p * dim + ax, p * dim + ax]
        if dr_now:
            for j in range(n - n_pos):
                dr_x[dr_next, j] = x[n_pos + j]
                dr_var[dr_next, j] = c[n_pos + j, n_pos + j]
            dr_next += 1
    return (
        xs, var, gamma, innov, innov_var, cp_x, cp_c, dr_x, dr_var, std_innov,
        jump_k[:n_jumps].copy(), jump_p[:n_jumps].copy(), jump_var[:n_jumps].copy(),
    )  # fmt: skip
