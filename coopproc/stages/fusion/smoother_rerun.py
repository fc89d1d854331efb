"""The smoother's re-run of one block of epochs from its checkpoint.

:mod:`coopproc.stages.fusion.smoother` does not store the K filtered covariances: each
block of about sqrt(K) epochs is filtered again from the checkpoint the forward pass kept,
with the forward pass's own code and robust factors (so bit for bit its covariances), and
what the backward pass reads is kept in a :class:`BlockBuffers`: the block's filtered
states (and covariances, or the recorded platforms' rows of them), every scalar update's
Jacobian row, gain, innovation and variance, the pending DR transitions it applied
(:mod:`~coopproc.stages.fusion.deferred`: per epoch, the platforms touched and their G;
and those still pending at the block's end, which the forward pass applied before the
next checkpoint) and the DR states' covariance rows at the epochs they are reported.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from coopproc.estimation.dr_model import PEND
from coopproc.model import FloatArray
from coopproc.stages.fusion.copies import copy1, copy2
from coopproc.stages.fusion.deferred import reads_all, touch_all, touch_epoch
from coopproc.stages.fusion.ekf import (
    epoch_buffers,
    epoch_innovations,
    epoch_update,
    max_epoch_obs,
    nav_at,
    time_update,
)
from coopproc.stages.fusion.kernel_types import (
    EpochWork,
    IntArray,
    NavCursor,
    Navigation,
    Observations,
    Process,
    Reads,
    Slots,
)

__all__ = ["BlockBuffers", "block_extent", "filter_epoch", "refit_checkpoints", "rerun_block"]


@numba.njit(cache=True, nogil=True)
def block_extent(
    obs_ptr: IntArray,
    rec_ptr: IntArray,
    dr_rec: IntArray,
    n_blocks: int,
    block: int,
    n_epochs: int,
) -> tuple[int, int, int]:
    """The most observations, recorded slots and DR-recorded epochs of any block (also of
    a :class:`~coopproc.stages.fusion.kernel_types.Reads`: its slots and ``every``)."""
    most = 0
    most_rec = 0
    most_dr = 0
    for b in range(n_blocks):
        lo = b * block
        hi = min(lo + block, n_epochs)
        most = max(most, obs_ptr[hi] - obs_ptr[lo])
        most_rec = max(most_rec, rec_ptr[hi] - rec_ptr[lo])
        dr_lo = int(np.searchsorted(dr_rec, lo))
        dr_hi = int(np.searchsorted(dr_rec, hi))
        most_dr = max(most_dr, dr_hi - dr_lo)
    return most, most_rec, most_dr


class BlockBuffers(NamedTuple):
    """One block's re-run: its filtered states, covariances (or the recorded platforms'
    rows of them), and every scalar update's Jacobian row, gain, innovation and variance,
    the touches of pending DR transitions (epoch k's are ``b_tplat``/``b_tg`` rows
    ``b_tptr[k - first]:b_tptr[k - first + 1]``; ``b_end``: what was pending at the
    block's end) and the DR states' covariance rows; with the per-epoch work arrays of
    the re-run."""

    bx: FloatArray
    bc: FloatArray
    b_rows: FloatArray
    b_idx: IntArray
    b_val: FloatArray
    b_cnt: IntArray
    b_gain: FloatArray
    b_y: FloatArray
    b_s: FloatArray
    b_tptr: IntArray
    b_tplat: IntArray
    b_tg: FloatArray
    b_end: FloatArray
    b_dr_rows: FloatArray
    work: EpochWork

    @classmethod
    def allocate(
        cls,
        block: int,
        n: int,
        dim: int,
        most: int,
        most_rec: int,
        max_m: int,
        with_var: bool,
        n_plat: int,
        most_dr: int,
        touches: int,
    ) -> BlockBuffers:
        width = 2 * dim
        rows = max(most, 1)
        return cls(
            bx=np.empty((block, n)),
            bc=np.empty((block if with_var else 1, n, n)),
            b_rows=np.empty((max(most_rec, 1) * dim, n)),
            b_idx=np.zeros((rows, width), dtype=np.int64),
            b_val=np.zeros((rows, width)),
            b_cnt=np.zeros(rows, dtype=np.int64),
            b_gain=np.zeros((rows, n)),
            b_y=np.zeros(rows),
            b_s=np.zeros(rows),
            b_tptr=np.zeros(block + 1, dtype=np.int64),
            b_tplat=np.zeros(max(touches, 1), dtype=np.int64),
            b_tg=np.zeros((max(touches, 1), PEND)),
            b_end=np.zeros((n_plat, PEND)),
            b_dr_rows=np.empty((max(most_dr, 1) * (n - n_plat * dim), n)),
            work=epoch_buffers(max_m, dim, n),
        )


@numba.njit(cache=True, nogil=True)
def filter_epoch(
    k: int,
    x: FloatArray,
    c: FloatArray,
    at: NavCursor,
    pend: FloatArray,
    nav: Navigation,
    proc: Process,
    obs: Observations,
    gamma: FloatArray,
    dim: int,
    work: EpochWork,
    keep: bool,
    gains: FloatArray,
    y: FloatArray,
    s_out: FloatArray,
    reads: Reads,
    followers: IntArray,
    every: bool,
    log_plat: IntArray,
    log_g: FloatArray,
    n_log: int,
) -> tuple[int, int]:
    """Epoch k of the forward filter with given robust factors, in place: the time update
    (pending DR transitions in ``pend``), the touches of the followers (``followers``) the
    epoch reads (its observations, the platforms ``reads.plat[reads.ptr[k]:reads.ptr[k +
    1]]``, all with ``every``; logged from ``n_log`` on when ``log_plat`` is not empty), the
    innovations and the batch update (``keep``: each scalar update's gain, innovation and
    variance to ``gains``, ``y``, ``s_out``, as
    :func:`~coopproc.stages.fusion.ekf_update.epoch_update`); returns the epoch's
    observation count and the log's length. ``ekf_forward``'s epoch without its robust
    step."""
    if k > 0:
        nav_at(nav.t, nav.v, nav.ptr, nav.epochs[k], at.cursor, at.now)
        time_update(
            x, c, at.now, at.prev, k, dim, proc, pend, proc.jump_k, proc.jump_p,
            proc.jump_var, proc.jump_k.shape[0],
        )  # fmt: skip
        copy2(at.prev, at.now)
    lo = obs.ptr[k]
    m = obs.ptr[k + 1] - lo
    if followers.shape[0] > 0:
        n_log = touch_epoch(
            c, pend, proc.dr_idx, followers, dim, obs, lo, m, reads.plat, reads.ptr[k],
            reads.ptr[k + 1], every, log_plat, log_g, n_log,
        )  # fmt: skip
    epoch_innovations(x, c, lo, m, obs, dim, work)
    epoch_update(
        x, c, lo, m, work, gamma, obs.r_var, keep, gains, y, s_out, pend, proc.dr_idx,
        followers, dim,
    )  # fmt: skip
    return m, n_log


@numba.njit(cache=True, nogil=True)
def rerun_block(
    b: int,
    cp_x: FloatArray,
    cp_c: FloatArray,
    nav: Navigation,
    proc: Process,
    obs: Observations,
    gamma: FloatArray,
    dim: int,
    slots: Slots,
    block: int,
    with_var: bool,
    dr_rec: IntArray,
    at: NavCursor,
    buf: BlockBuffers,
    reads: Reads,
) -> None:
    """Re-run the forward filter over block ``b`` from its checkpoint, keeping what the
    backward pass reads in ``buf`` (the forward pass's own code and robust factors: the
    same bits)."""
    obs_ptr = obs.ptr
    rec_ptr, rec_plat = slots
    n_epochs = proc.dt.shape[0]
    first = b * block
    last = min(first + block, n_epochs)
    base = obs_ptr[first]
    rec_base = rec_ptr[first]
    x = cp_x[b].copy()
    c = cp_c[b].copy()
    n = x.shape[0]
    n_pos = (nav.ptr.shape[0] - 1) * dim
    n_dr = n - n_pos
    dr_next = np.searchsorted(dr_rec, first)
    dr_base = dr_next
    h_idx, h_val, h_cnt = buf.work.h_idx, buf.work.h_val, buf.work.h_cnt
    pend = np.zeros((nav.ptr.shape[0] - 1, PEND))  # a checkpoint has nothing pending
    followers = np.flatnonzero(proc.dr_idx >= 0)
    every_next = int(np.searchsorted(reads.every, first))
    n_log = 0
    # the navigation at the epoch before the block (the cursor searches back)
    nav_at(nav.t, nav.v, nav.ptr, nav.epochs[max(first - 1, 0)], at.cursor, at.prev)
    for k in range(first, last):
        lo = obs_ptr[k] - base
        hi = obs_ptr[k + 1] - base
        buf.b_tptr[k - first] = n_log
        every, every_next = reads_all(reads.every, every_next, k)
        m, n_log = filter_epoch(
            k, x, c, at, pend, nav, proc, obs, gamma, dim, buf.work, bool(np.bool_(True)),
            buf.b_gain[lo:hi], buf.b_y[lo:hi], buf.b_s[lo:hi], reads, followers, every,
            buf.b_tplat, buf.b_tg, n_log,
        )  # fmt: skip
        for j in range(m):
            buf.b_cnt[lo + j] = h_cnt[j]
            for p in range(h_cnt[j]):
                buf.b_idx[lo + j, p] = h_idx[j, p]
                buf.b_val[lo + j, p] = h_val[j, p]
        copy1(buf.bx[k - first], x)
        if with_var:
            copy2(buf.bc[k - first], c)
        for r in range(rec_ptr[k], rec_ptr[k + 1]):
            p = rec_plat[r]
            for ax in range(dim):
                copy1(buf.b_rows[(r - rec_base) * dim + ax], c[p * dim + ax])
        if dr_next < dr_rec.shape[0] and dr_rec[dr_next] == k:
            for j in range(n_dr):
                copy1(buf.b_dr_rows[(dr_next - dr_base) * n_dr + j], c[n_pos + j])
            dr_next += 1
    buf.b_tptr[last - first] = n_log
    # what the forward pass applies before the next checkpoint (dr_model: "Deferred")
    copy2(buf.b_end, pend)


@numba.njit(cache=True, nogil=True)
def refit_checkpoints(
    b0: int,
    cp_x: FloatArray,
    cp_c: FloatArray,
    nav: Navigation,
    proc: Process,
    obs: Observations,
    gamma: FloatArray,
    dim: int,
    block: int,
    reads: Reads,
) -> None:
    """The robust refit's forward pass (:mod:`~coopproc.stages.fusion.robust_refit`) from
    checkpoint ``b0`` on: the checkpoints after it, in place, with the refit's factors.

    The refit changes the factors of some observations only; before the first of them
    (in block ``b0``) the filter is the pass before's, bit for bit, and so are its
    checkpoints up to ``b0``: only the later ones are filtered again (the forward pass's
    own code and ``reads``, as :func:`rerun_block`). ``b0`` past the last block: nothing
    changed.
    """
    n_epochs = proc.dt.shape[0]
    n_blocks = cp_x.shape[0]
    if b0 >= n_blocks:
        return
    first = b0 * block
    x = cp_x[b0].copy()
    c = cp_c[b0].copy()
    n = x.shape[0]
    n_plat = nav.ptr.shape[0] - 1
    work = epoch_buffers(max_epoch_obs(obs.ptr), dim, n)
    unused = np.zeros((1, 1))
    unused_v = np.zeros(1)
    at = NavCursor(
        np.full(n_plat, -1, dtype=np.int64), np.zeros((n_plat, dim)), np.zeros((n_plat, dim))
    )
    pend = np.zeros((n_plat, PEND))
    followers = np.flatnonzero(proc.dr_idx >= 0)
    every_next = int(np.searchsorted(reads.every, first))
    no_log = np.zeros(0, np.int64)
    no_log_g = np.zeros((0, PEND))
    nav_at(nav.t, nav.v, nav.ptr, nav.epochs[max(first - 1, 0)], at.cursor, at.prev)
    for k in range(first, n_epochs):
        if k % block == 0 and k > first:  # the true covariance, as the forward pass's
            touch_all(c, pend, proc.dr_idx, followers, dim, no_log, no_log_g, 0)
            copy1(cp_x[k // block], x)
            copy2(cp_c[k // block], c)
        every, every_next = reads_all(reads.every, every_next, k)
        filter_epoch(
            k, x, c, at, pend, nav, proc, obs, gamma, dim, work, bool(np.bool_(False)),
            unused, unused_v, unused_v, reads, followers, every, no_log, no_log_g, 0,
        )  # fmt: skip
