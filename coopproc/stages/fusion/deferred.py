"""Which followers' pending transitions the cooperative EKF applies at an epoch.

With DR states a follower's transition is not applied to the covariance at every epoch
but multiplied into a pending G and applied when something reads the follower
(:mod:`~coopproc.estimation.dr_model`, "Deferred transitions"): at an epoch the filter
*touches* the followers its observations involve (both ends of a range, the platform of
an anchor range or a fix), the platforms any pass records a state of, and every
follower where DR states may be recorded (the report grid) or a smoother checkpoint is
kept (the checkpoints hold the true covariance, so a block's re-run starts with nothing
pending). The smoother's
re-run logs each touch (platform and G) for the backward pass, which takes the same
steps in reverse (:func:`~coopproc.estimation.dr_model.adjoint_touch`).

The schedule (:class:`~coopproc.stages.fusion.kernel_types.Reads`) is the same for every
pass of a fusion, whatever each pass records, so the forward pass, the smoother's re-runs
and the refit are the same arithmetic, bit for bit. Where each follower is read at every
epoch the filter is the eager one; the order of the touches only changes rounding.
"""

from __future__ import annotations

import numba

from coopproc.estimation.dr_model import PEND, touch
from coopproc.model import FloatArray
from coopproc.stages.fusion.ekf_update import OBS_RANGE
from coopproc.stages.fusion.kernel_types import IntArray, Observations

__all__ = ["reads_all", "touch_all", "touch_epoch"]


@numba.njit(cache=True, nogil=True)
def reads_all(every: IntArray, at: int, k: int) -> tuple[bool, int]:
    """Whether epoch k reads every follower (``every``: the ascending epochs that do, a
    pass's cursor ``at`` into it, the first not yet passed), and the cursor after k."""
    if at < every.shape[0] and every[at] == k:
        return True, at + 1
    return False, at


@numba.njit(cache=True, nogil=True, inline="always")
def _touch_one(
    c: FloatArray,
    pend: FloatArray,
    p: int,
    dr_idx: IntArray,
    dim: int,
    log_plat: IntArray,
    log_g: FloatArray,
    n_log: int,
) -> int:
    """Apply platform p's pending G (if any), logged at ``n_log`` when a log is kept."""
    e = dr_idx[p]
    if e < 0 or pend[p, 0] == 0.0:
        return n_log
    if log_plat.shape[0] > 0:
        log_plat[n_log] = p
        for j in range(PEND):
            log_g[n_log, j] = pend[p, j]
        n_log += 1
    touch(c, p * dim, e, pend[p])
    return n_log


@numba.njit(cache=True, nogil=True)
def touch_epoch(
    c: FloatArray,
    pend: FloatArray,
    dr_idx: IntArray,
    followers: IntArray,
    dim: int,
    obs: Observations,
    lo: int,
    m: int,
    rec_plat: IntArray,
    r0: int,
    r1: int,
    every: bool,
    log_plat: IntArray,
    log_g: FloatArray,
    n_log: int,
) -> int:
    """Touch the followers epoch k reads (its observations ``lo:lo + m``, its recorded
    platforms ``rec_plat[r0:r1]``, all with ``every``), in that order; with a log
    (``log_plat`` not empty) each touch goes to ``log_plat``/``log_g`` from ``n_log`` on.
    Returns the log's new length. ``followers``: the platforms with DR states (none: the
    position-only filter, nothing to do)."""
    if followers.shape[0] == 0:
        return n_log
    if every:
        return touch_all(c, pend, dr_idx, followers, dim, log_plat, log_g, n_log)
    for j in range(m):
        o = lo + j
        n_log = _touch_one(c, pend, obs.a[o], dr_idx, dim, log_plat, log_g, n_log)
        if obs.kind[o] == OBS_RANGE:
            n_log = _touch_one(c, pend, obs.b[o], dr_idx, dim, log_plat, log_g, n_log)
    for r in range(r0, r1):
        n_log = _touch_one(c, pend, rec_plat[r], dr_idx, dim, log_plat, log_g, n_log)
    return n_log


@numba.njit(cache=True, nogil=True)
def touch_all(
    c: FloatArray,
    pend: FloatArray,
    dr_idx: IntArray,
    followers: IntArray,
    dim: int,
    log_plat: IntArray,
    log_g: FloatArray,
    n_log: int,
) -> int:
    """Touch every follower with a pending transition, in platform order (logged as
    :func:`touch_epoch`); returns the log's new length."""
    for f in range(followers.shape[0]):
        n_log = _touch_one(c, pend, followers[f], dr_idx, dim, log_plat, log_g, n_log)
    return n_log
