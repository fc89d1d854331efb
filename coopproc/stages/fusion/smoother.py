"""Fixed-interval smoother of the cooperative EKF, memory-bounded and O(n^2) per epoch.

Paper 003 section 2.8 smooths with the Rauch-Tung-Striebel recursion
A_k = C_k (C^-_{k+1})^-1, X^s_k = X_k + A_k (X^s_{k+1} - X^-_{k+1}),
C^s_k = C_k + A_k (C^s_{k+1} - C^-_{k+1}) A_k^T. It needs every epoch's filtered covariance
(K x n x n: 12 GB for a day of 10 platforms at 45 range epochs per second) and an n x n
inversion per epoch (O(n^3)). This module computes the same smoothed states and variances
with the equivalent modified Bryson-Frazier form (Bierman 1977), which for our model
(F = I, control input u, additive Q, observations processed as scalar updates) is

- backward adjoints, starting from lambda = 0, Lambda = 0 after the last epoch; the time
  update leaves them unchanged where F = I, and maps them by lambda <- F^T lambda,
  Lambda <- F^T Lambda F where a follower carries DR states (F = I + E, O(n) per
  follower, taken where the forward filter applied it: a follower's epochs' F multiplied
  into one G when it is next read, :mod:`~coopproc.stages.fusion.deferred`,
  :func:`~coopproc.estimation.dr_model.adjoint_touch`); each scalar update
  j (gain g = C h / s, corrected innovation y, variance s = h C h^T + R / gamma,
  eq. (15)-(17)), taken in reverse order, maps them by
  lambda <- (I - g h^T)^T lambda - h y / s,
  Lambda <- (I - g h^T)^T Lambda (I - g h^T) + h h^T / s;
- smoothed epoch k from its filtered (posterior) X_k, C_k and the adjoints of the later
  epochs: X^s_k = X_k - C_k lambda, C^s_k = C_k - C_k Lambda C_k (only the diagonal
  entries of the recorded platforms are formed).

h has at most 2 dim non-zeros, so each step costs O(n^2) and no matrix is inverted.
Q does not appear: it is in the filtered C_k. The filtered C_k are not stored: each block of
epochs is re-run forward from the checkpoint ``ekf_forward`` kept, with the same code and the
forward pass's robust factors, so the covariances are bit for bit the forward ones. Memory:
the checkpoints plus one block (about 2 sqrt(K) covariances; without the smoothed
variances a block keeps only the recorded platforms' rows of C_k, all the states need).
Lambda is kept symmetric bit for bit (the few entries that two updates reach in two
orders are averaged with their mirror), so Lambda g, the O(n^2) part of each backward
step, sums contiguous rows (vectorized), and the transition's columns are copies of its
rows (:func:`~coopproc.estimation.dr_model.adjoint_touch`). The tests check the result
against the dense RTS recursion.

The re-runs do not depend on the backward pass nor on each other (each starts from its
checkpoint), so on a machine with two cores or more :func:`mbf_backward` runs two re-runs
at once in worker threads while the backward pass takes the block after them (the
compiled loops release the GIL): the re-runs, four fifths of a pass's work with the DR
states, take about half their time, with the same arithmetic, so the same bits. (Until
2026-12-08 one worker ran the re-runs one after the other beside the backward pass, issue
11: a pass cost the re-runs' time.) A pass that forms no variance (no smoothed sigmas, no
DR states reported) carries lambda only: the states need nothing of Lambda.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from coopproc.estimation.dr_model import adjoint_touch, adjoint_touch_vector
from coopproc.model import FloatArray
from coopproc.stages.fusion.ekf import max_epoch_obs
from coopproc.stages.fusion.kernel_types import (
    Adjoints,
    IntArray,
    NavCursor,
    Navigation,
    Observations,
    Process,
    Reads,
    Slots,
    Smoothed,
)
from coopproc.stages.fusion.smoother_rerun import BlockBuffers, block_extent, rerun_block

__all__ = ["mbf_backward"]


@numba.njit(cache=True, nogil=True, inline="always")
def _lambda_times(lam_t: FloatArray, v: FloatArray, out: FloatArray) -> None:
    """``out`` = Lambda v, as sum over ll ascending of Lambda[ll, :] v[ll]: each entry's
    sum in the order of a dot product of Lambda's column with v (so the same bits), but
    as row-by-row multiply-adds that vectorize, where a dot product's strict order of
    additions runs one at a time (the DR states' variances at 20 platforms: n_dr n^2 per
    reported second; each update's Lambda g)."""
    n = out.shape[0]
    for i in range(n):
        out[i] = 0.0
    for ll in range(n):
        vl = v[ll]
        row = lam_t[ll]
        for i in range(n):
            out[i] += row[i] * vl


@numba.njit(cache=True, nogil=True)
def _backward_block(
    b: int,
    obs_ptr: IntArray,
    slots: Slots,
    dim: int,
    block: int,
    with_var: bool,
    with_lam: bool,
    buf: BlockBuffers,
    proc: Process,
    dr_rec: IntArray,
    adj: Adjoints,
    out: Smoothed,
) -> None:
    """The backward pass over block ``b`` (re-run into the given buffers): the smoothed
    recorded slots of its epochs (into ``out``), and the adjoints carried to the block
    before (in ``adj``). ``with_lam``: carry Lambda too (False: lambda only, no variance
    asked: :func:`mbf_backward`)."""
    rec_ptr, rec_plat = slots
    bx, bc, b_rows, b_idx, b_val, b_cnt = (
        buf.bx,
        buf.bc,
        buf.b_rows,
        buf.b_idx,
        buf.b_val,
        buf.b_cnt,
    )
    b_gain, b_y, b_s, b_dr_rows = buf.b_gain, buf.b_y, buf.b_s, buf.b_dr_rows
    b_tptr, b_tplat, b_tg, b_end = buf.b_tptr, buf.b_tplat, buf.b_tg, buf.b_end
    dr_idx, dt = proc.dr_idx, proc.dt
    lam, lam_t, lam_g, col = adj
    xs, var, dr_xs, dr_var = out
    n_epochs = dt.shape[0]
    n = lam.shape[0]
    first = b * block
    last = min(first + block, n_epochs)
    base = obs_ptr[first]
    rec_base = rec_ptr[first]
    n_plat = dr_idx.shape[0]
    n_pos = n_plat * dim
    n_dr = n - n_pos
    dr_base = np.searchsorted(dr_rec, first)
    dr_next = np.searchsorted(dr_rec, last) - 1
    if last < n_epochs:  # back through what the forward pass applied before checkpoint b + 1
        for p in range(n_plat - 1, -1, -1):
            if b_end[p, 0] != 0.0:
                if with_lam:
                    adjoint_touch(lam, lam_t, p * dim, dr_idx[p], b_end[p])
                else:
                    adjoint_touch_vector(lam, p * dim, dr_idx[p], b_end[p])
    for k in range(last - 1, first - 1, -1):
        xf = bx[k - first]
        if dr_next >= dr_base and dr_rec[dr_next] == k:  # the DR states, as the positions
            for j in range(n_dr):
                c_row = b_dr_rows[(dr_next - dr_base) * n_dr + j]
                acc = xf[n_pos + j]
                for jj in range(n):
                    acc -= c_row[jj] * lam[jj]
                dr_xs[dr_next, j] = acc
                _lambda_times(lam_t, c_row, col)
                quad = 0.0
                for jj in range(n):
                    quad += c_row[jj] * col[jj]
                dr_var[dr_next, j] = c_row[n_pos + j] - quad
            dr_next -= 1
        for r in range(rec_ptr[k], rec_ptr[k + 1]):  # X_k - C_k lambda, C_k - C_k L C_k
            p = rec_plat[r]
            for ax in range(dim):
                i = p * dim + ax
                c_row = b_rows[(r - rec_base) * dim + ax]
                acc = xf[i]
                for jj in range(n):
                    acc -= c_row[jj] * lam[jj]
                xs[r, ax] = acc
                if not with_var:
                    continue
                cf = bc[k - first]
                _lambda_times(lam_t, cf[:, i], col)
                quad = 0.0
                for jj in range(n):
                    quad += cf[i, jj] * col[jj]
                var[r, ax] = cf[i, i] - quad
        for o in range(obs_ptr[k + 1] - 1, obs_ptr[k] - 1, -1):  # scalar updates, reversed
            j = o - base
            cnt = b_cnt[j]
            g = b_gain[j]
            g_lam = 0.0
            for i in range(n):
                g_lam += g[i] * lam[i]
            shift = g_lam + b_y[j] / b_s[j]
            for p in range(cnt):
                lam[b_idx[j, p]] -= b_val[j, p] * shift
            if not with_lam:  # lambda's step needs nothing of Lambda
                continue
            _lambda_times(lam_t, g, lam_g)  # Lambda g
            g_lam_g = 0.0
            for i in range(n):
                g_lam_g += g[i] * lam_g[i]
            for p in range(cnt):  # Lambda[row, :] -= h lam_g (a column of lam_t)
                row = b_idx[j, p]
                hv = b_val[j, p]
                for i in range(n):
                    lam_t[i, row] -= hv * lam_g[i]
            for p in range(cnt):  # Lambda[:, column] -= lam_g h (a row of lam_t)
                column = b_idx[j, p]
                hv = b_val[j, p]
                row_t = lam_t[column]
                for i in range(n):
                    row_t[i] -= lam_g[i] * hv
            extra = g_lam_g + 1.0 / b_s[j]
            for p in range(cnt):
                for s_ in range(cnt):
                    lam_t[b_idx[j, s_], b_idx[j, p]] += b_val[j, p] * b_val[j, s_] * extra
            for p in range(cnt):  # h's entries took both subtractions in two orders
                for s_ in range(p + 1, cnt):
                    r_, c_ = b_idx[j, p], b_idx[j, s_]
                    sym = 0.5 * (lam_t[r_, c_] + lam_t[c_, r_])
                    lam_t[r_, c_] = sym
                    lam_t[c_, r_] = sym
        # back through the transitions epoch k applied (its touches, in reverse): G^T lambda,
        # G^T Lambda G (dr_model: "Deferred transitions")
        for t in range(b_tptr[k - first + 1] - 1, b_tptr[k - first] - 1, -1):
            p = b_tplat[t]
            if with_lam:
                adjoint_touch(lam, lam_t, p * dim, dr_idx[p], b_tg[t])
            else:
                adjoint_touch_vector(lam, p * dim, dr_idx[p], b_tg[t])


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def mbf_backward(
    cp_x: FloatArray,
    cp_c: FloatArray,
    nav: Navigation,
    proc: Process,
    obs: Observations,
    gamma: FloatArray,
    dim: int,
    slots: Slots,
    block: int,
    with_var: bool = True,
    threads: int | None = None,
    dr_rec: IntArray | None = None,
    reads: Reads | None = None,
) -> Smoothed:
    """Smoothed states and variances (R, dim) at the recorded slots (see the module doc).

    ``cp_x``, ``cp_c``, ``gamma`` come from :func:`~coopproc.stages.fusion.ekf.ekf_forward`
    run with the same inputs and ``block``. ``with_var=False`` gives no variances, an empty
    (0, dim) array (they cost n^2 per recorded value, more than the states; the run's
    tables do not use them). ``threads``: the re-runs run at once (2: two worker
    threads re-run the next blocks while the backward pass takes this one; 1: re-run
    and backward pass in turn; None: 2 when this process may use two cores or more);
    the result is the same, bit for bit.
    ``dr_rec``: the epochs the DR states are reported at, as given to ``ekf_forward``
    (None: none); the smoothed DR states and their variances there are returned after
    the positions' (always with variances: a few per second). ``reads``: the forward
    pass's (:func:`~coopproc.stages.fusion.ekf.ekf_forward`; None: ``slots`` and
    ``dr_rec``), where the followers' pending DR transitions are applied.
    """
    n_epochs = proc.dt.shape[0]
    n = cp_x.shape[1]
    n_blocks = cp_x.shape[0]
    n_rec = slots.plat.shape[0]
    n_plat = nav.ptr.shape[0] - 1
    if dr_rec is None:
        dr_rec = np.zeros(0, dtype=np.int64)
    if reads is None:
        reads = Reads(slots.ptr, slots.plat, dr_rec)
    n_dr = n - n_plat * dim
    out = Smoothed(
        xs=np.empty((n_rec, dim)),
        var=np.empty((n_rec if with_var else 0, dim)),
        dr_xs=np.empty((dr_rec.shape[0], n_dr)),
        dr_var=np.empty((dr_rec.shape[0], n_dr)),
    )
    # Lambda, symmetric bit for bit (module doc), so its rows are its columns: Lambda g
    # is a sum of contiguous rows, vectorized (the name from when the transpose was kept)
    # Lambda only where a variance is formed: the states need lambda alone (X_k - C_k
    # lambda), so a pass without variances skips Lambda's O(n^2) per scalar update
    with_lam = bool(np.bool_(with_var or dr_rec.shape[0] > 0))  # a run-time bool (ekf_update)
    m = n if with_lam else 1
    adj = Adjoints(lam=np.zeros(n), lam_t=np.zeros((m, m)), lam_g=np.zeros(n), col=np.zeros(n))
    if n_blocks == 0:
        return out
    max_m = max_epoch_obs(obs.ptr)
    most, most_rec, most_dr = block_extent(obs.ptr, slots.ptr, dr_rec, n_blocks, block, n_epochs)
    _, most_read, most_every = block_extent(
        obs.ptr, reads.ptr, reads.every, n_blocks, block, n_epochs
    )
    # the touches of a block: at most both ends of every observation, every platform read
    # and every platform at the epochs all are read
    touches = 2 * most + most_read + most_every * n_plat
    lanes = threads if threads is not None else min(_cpu_count(), 2)
    pipelined = lanes >= 2 and n_blocks > 1
    # pipelined: ``lanes`` re-runs at once (each into a buffer and with a navigation cursor
    # of its own) while the backward pass reads the buffer before them
    n_buf = lanes + 1 if pipelined else 1
    buffers = [
        BlockBuffers.allocate(
            block, n, dim, most, most_rec, max_m, with_var, n_plat, most_dr, touches
        )
        for _ in range(n_buf)
    ]
    cursors = [NavCursor.allocate(n_plat, dim) for _ in range(n_buf)]

    def rerun(b: int) -> None:
        rerun_block(
            b,
            cp_x,
            cp_c,
            nav,
            proc,
            obs,
            gamma,
            dim,
            slots,
            block,
            with_var,
            dr_rec,
            cursors[b % n_buf],
            buffers[b % n_buf],
            reads,
        )

    def backward(b: int) -> None:
        buf = buffers[b % n_buf]
        _backward_block(
            b, obs.ptr, slots, dim, block, with_var, with_lam, buf, proc, dr_rec, adj, out
        )

    if not pipelined:
        for b in range(n_blocks - 1, -1, -1):
            rerun(b)
            backward(b)
        return out
    # the re-runs are independent (each starts from its checkpoint); the re-run of
    # b - lanes takes the buffer of b + 1, whose backward pass is done
    with ThreadPoolExecutor(max_workers=lanes, thread_name_prefix="smoother") as pool:
        last = n_blocks - 1
        ahead = {b: pool.submit(rerun, b) for b in range(last, max(last - lanes, -1), -1)}
        for b in range(last, -1, -1):
            if b - lanes >= 0:
                ahead[b - lanes] = pool.submit(rerun, b - lanes)
            ahead.pop(b).result()
            backward(b)
    return out
