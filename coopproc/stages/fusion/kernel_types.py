"""The cooperative fusion's compiled kernels' inputs, as small typed structures.

The forward EKF (:mod:`~coopproc.stages.fusion.ekf`), the smoother's re-run and backward
pass (:mod:`~coopproc.stages.fusion.smoother_rerun`, :mod:`~coopproc.stages.fusion.smoother`)
and the robust refit share the same inputs; each group is one ``NamedTuple`` of arrays,
which numba passes to compiled code as a tuple (an attribute read costs nothing), so a
kernel takes a handful of arguments instead of dozens of positional arrays (issue 34
part 1). The fields are the arrays :func:`~coopproc.stages.fusion.fuse.fuse` builds;
each docstring says what the kernels read from it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = [
    "Adjoints",
    "EpochWork",
    "IntArray",
    "NavCursor",
    "Navigation",
    "Observations",
    "Process",
    "Reads",
    "Robust",
    "Slots",
    "Smoothed",
]

IntArray = NDArray[np.int64]


class Navigation(NamedTuple):
    """The fusion epochs (K,) and every moving platform's navigation samples as
    :func:`~coopproc.stages.fusion.nav_kernel.nav_at` reads them: times ``t`` (S,),
    positions ``v`` (S, dim), platform p's samples at ``ptr[p]:ptr[p + 1]``."""

    epochs: FloatArray
    t: FloatArray
    v: FloatArray
    ptr: IntArray


class Process(NamedTuple):
    """The process model of :func:`~coopproc.stages.fusion.ekf.time_update`: the position
    noise coefficient per platform ``q_coef`` (P,) (``q_squared``: (q dt)^2, else q dt),
    the epochs' steps ``dt`` (K,), and the DR states' index ``dr_idx`` (P,) (-1: none)
    and random walks ``dr_q`` (P, 5) (:mod:`~coopproc.estimation.dr_model`); and the
    dead-reckoning faults' extra position variance: at epoch ``jump_k[j]`` (sorted)
    platform ``jump_p[j]``'s horizontal axes get ``jump_var[j]`` m^2 each
    (:mod:`~coopproc.stages.fusion.dr_faults`: none for the forward pass, which finds them;
    its jumps for the smoother's re-runs, and the confirmed, spread ones for the refit)."""

    q_coef: FloatArray
    q_squared: bool
    dt: FloatArray
    dr_idx: IntArray
    dr_q: FloatArray
    jump_k: IntArray
    jump_p: IntArray
    jump_var: FloatArray

    @classmethod
    def without_dr(cls, q_coef: FloatArray, q_squared: bool, dt: FloatArray) -> Process:
        """The position-only model (no platform carries DR states)."""
        n_plat = q_coef.shape[0]
        return cls.of(q_coef, q_squared, dt, np.full(n_plat, -1, np.int64), np.zeros((n_plat, 5)))

    @classmethod
    def of(
        cls,
        q_coef: FloatArray,
        q_squared: bool,
        dt: FloatArray,
        dr_idx: IntArray,
        dr_q: FloatArray,
    ) -> Process:
        """The model without dead-reckoning faults."""
        none = np.zeros(0, np.int64)
        return cls(q_coef, q_squared, dt, dr_idx, dr_q, none, none.copy(), np.zeros(0))


class Observations(NamedTuple):
    """Every observation, CSR by epoch (epoch k's are ``ptr[k]:ptr[k + 1]``): its kind,
    platforms ``a``/``b``, row ``anchor`` of ``anchor_tab`` (the fixed point or offset),
    squared out-of-plane term ``dz2``, value ``z`` and variance ``r_var``
    (:mod:`~coopproc.stages.fusion.ekf_update`)."""

    ptr: IntArray
    kind: NDArray[np.integer]
    a: NDArray[np.integer]
    b: NDArray[np.integer]
    anchor: NDArray[np.integer]
    anchor_tab: FloatArray
    dz2: FloatArray
    z: FloatArray
    r_var: FloatArray


class Robust(NamedTuple):
    """The robust update's settings (paper 002 eq. (18)-(20)): on or off, k0, k1, the MAD
    sigma's floor and the window of earlier innovations a small epoch pools with; the span
    (s) over which a platform's ranges are judged for a jump of its dead reckoning
    (:mod:`~coopproc.stages.fusion.dr_faults`; 0: not judged), and whether a jump found is
    given as process noise (False: found and reported only)."""

    robust: bool
    k0: float
    k1: float
    sigma_floor: float
    mad_window: int
    fault_window: float = 0.0
    fault_apply: bool = True


class Slots(NamedTuple):
    """The recorded (epoch, platform) slots, CSR by epoch: epoch k's are platforms
    ``plat[ptr[k]:ptr[k + 1]]``."""

    ptr: IntArray
    plat: IntArray


class Reads(NamedTuple):
    """What the filter reads of each epoch besides its observations, CSR by epoch as
    :class:`Slots`: the platforms ``plat[ptr[k]:ptr[k + 1]]`` (the recorded slots of any
    pass: the forward pass, the smoother, the refit), and the epochs ``every`` (ascending)
    at which every follower's DR states are (the DR report grid). A follower's pending
    transition is applied where it is read (:mod:`~coopproc.stages.fusion.deferred`); one
    schedule for every pass of a fusion, whatever each records, keeps them the same
    arithmetic, bit for bit."""

    ptr: IntArray
    plat: IntArray
    every: IntArray


class EpochWork(NamedTuple):
    """One epoch's work arrays (:func:`~coopproc.stages.fusion.ekf_update.epoch_buffers`):
    Jacobian rows (indices, values, counts), innovations, their variances, C h, the prior."""

    h_idx: IntArray
    h_val: FloatArray
    h_cnt: IntArray
    v: FloatArray
    d: FloatArray
    ph: FloatArray
    x_prior: FloatArray


class NavCursor(NamedTuple):
    """Where :func:`~coopproc.stages.fusion.nav_kernel.nav_at` is in each platform's
    samples, and the navigation at the epoch before and at this one (P, dim)."""

    cursor: IntArray
    prev: FloatArray
    now: FloatArray

    @classmethod
    def allocate(cls, n_plat: int, dim: int) -> NavCursor:
        return cls(np.full(n_plat, -1, np.int64), np.zeros((n_plat, dim)), np.zeros((n_plat, dim)))


class Adjoints(NamedTuple):
    """The smoother's backward adjoints lambda (n,) and Lambda (n, n), and its two work
    vectors (Lambda g and one column), :mod:`~coopproc.stages.fusion.smoother`."""

    lam: FloatArray
    lam_t: FloatArray
    lam_g: FloatArray
    col: FloatArray


class Smoothed(NamedTuple):
    """The smoother's results: states and variances at the recorded slots (R, dim), the DR
    states and their variances at the epochs they are reported (E, n - P dim)."""

    xs: FloatArray
    var: FloatArray
    dr_xs: FloatArray
    dr_var: FloatArray
