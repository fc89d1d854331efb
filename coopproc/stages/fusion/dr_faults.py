"""A platform whose dead reckoning jumped: found in the forward filter, given as process noise.

A wheel slip (the odometer over-reads for a few seconds) moves a platform's dead-reckoned
path by tens of centimetres, and the path stays off by that much. The process model (a
random walk of the position, the heading and scale states of
:mod:`~coopproc.estimation.dr_model`) cannot follow a jump: after one, the filter's
prediction of the platform is off, IGG-III (paper 002 eq. (18)) rejects the ranges it
takes or the filter bends its heading and scale states to them, and the smoother, with no
process noise to carry a step, spreads the correction over tens of seconds (the simulated
``dr-faults`` scenario; real wheeled robots slip too).

NLOS is one pair's error; a platform that is off shows in all its pairs, in the
directions of its partners. So the forward filter keeps each platform's ranges of the
last ``fault_window`` seconds (innovation at the prior, its standardizing sigma with and
without the MAD factor of eq. (20), the Jacobian on the platform's horizontal position,
the partner) and, once a :data:`DECORRELATION_S`, judges a platform that is an end of the
epoch's ranges (:func:`_judge`): with ranges to three or more partners (anchors count), two
or more of them off on their own (the weighted mean of the partner's innovations beyond
k0), one horizontal shift ``delta`` is fitted to all of them (weighted least squares, a
partner's ranges within :data:`DECORRELATION_S` counting as one); if it reduces the sum of
squared standardized innovations by :data:`JUMP_CHI2` or more and leaves every range
within k0 of the model's innovation sigma, the platform, not its ranges, is off. The
filter then adds ``|delta|^2`` to the variance of each of its horizontal coordinates at
the next epoch's time update, records the jump (the smoother's re-runs take the same) and
forgets the platform's kept ranges, so that a second jump needs new evidence; a partner
that jumped is left out of its partners' evidence for a window. With two partners a shift
fits any two residuals, so three are needed; leaders are left out (their fixes place
them). The robust refit keeps the jumps the smoothed solution confirms
(:func:`confirmed_jumps`) and spreads each over the span before it was found
(:func:`spread_jumps`). docs/methods-fusion.md ("A platform whose dead reckoning jumped")
has the measurements and which data each constant was chosen on.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.stages.fusion.ekf_update import OBS_ANCHOR, OBS_POSITION, OBS_RANGE
from coopproc.stages.fusion.kernel_types import (
    EpochWork,
    IntArray,
    Navigation,
    Observations,
    Process,
    Slots,
)

__all__ = [
    "CAPACITY",
    "CONFIRM_FRACTION",
    "JUMP_CHI2",
    "JUMP_COLUMNS",
    "SPREAD_WINDOWS",
    "FaultBuffers",
    "confirmed_jumps",
    "fault_buffers",
    "judge_epoch",
    "jumps_of",
    "jumps_table",
    "leaders",
    "spread_jumps",
    "take_jumps",
]

#: ranges kept per platform: a 5 s window at 1 Hz a pair holds 5 a partner, 45 with nine
#: partners; at higher rates the window is the last CAPACITY ranges (real TIERS, 7 Hz a
#: pair and six partners: about 1.5 s)
CAPACITY = 64


class FaultBuffers(NamedTuple):
    """Each platform's kept ranges (P, CAPACITY): time, partner code (platform index, or
    -1 - anchor), the Jacobian on its horizontal position (P, CAPACITY, 2), innovation,
    standardizing sigma with the MAD factor of eq. (20) and without it (m); per platform
    (P,) how many are kept and the next slot, the variance to add at the next time update
    (a jump found, which the filter takes and records), the time of its last jump and of
    its next judging; and work arrays of the judging."""

    t: FloatArray
    partner: IntArray
    jac: FloatArray
    v: FloatArray
    scale: FloatArray
    unit: FloatArray
    kept: IntArray
    head: IntArray
    pending: FloatArray
    last_jump: FloatArray
    next_judged: FloatArray
    work_i: IntArray
    work_f: FloatArray


@numba.njit(cache=True)
def fault_buffers(n_plat: int) -> FaultBuffers:
    """Empty buffers for ``n_plat`` platforms."""
    return FaultBuffers(
        np.zeros((n_plat, CAPACITY)),
        np.zeros((n_plat, CAPACITY), np.int64),
        np.zeros((n_plat, CAPACITY, 2)),
        np.zeros((n_plat, CAPACITY)),
        np.ones((n_plat, CAPACITY)),
        np.ones((n_plat, CAPACITY)),
        np.zeros(n_plat, np.int64),
        np.zeros(n_plat, np.int64),
        np.zeros(n_plat),
        np.full(n_plat, -np.inf),
        np.full(n_plat, -np.inf),
        np.zeros(CAPACITY, np.int64),
        np.zeros((2, CAPACITY)),
    )


@numba.njit(cache=True)
def leaders(obs: Observations, n_plat: int) -> np.ndarray:
    """The platforms with a position fix of their own (their fixes place them)."""
    fixed = np.zeros(n_plat, np.bool_)
    for j in range(obs.kind.shape[0]):
        if obs.kind[j] == OBS_POSITION:
            fixed[obs.a[j]] = True
    return fixed


@numba.njit(cache=True)
def _push(
    fb: FaultBuffers, p: int, t: float, partner: int, ju: float, jn: float, v: float,
    scale: float, unit: float,
) -> None:  # fmt: skip
    h = fb.head[p]
    fb.t[p, h] = t
    fb.partner[p, h] = partner
    fb.jac[p, h, 0] = ju
    fb.jac[p, h, 1] = jn
    fb.v[p, h] = v
    fb.scale[p, h] = scale
    fb.unit[p, h] = unit
    fb.head[p] = (h + 1) % CAPACITY
    fb.kept[p] = min(fb.kept[p] + 1, CAPACITY)


#: the evidence for a jump: the weighted least-squares shift's reduction of the sum of
#: squared standardized innovations (chi-square, 2 degrees of freedom: 25 is exceeded by
#: chance with probability 4e-6)
JUMP_CHI2 = 25.0

#: ranges of one partner within this many seconds count as one piece of evidence: UWB
#: range errors are correlated over a fraction of a second (real TIERS, ranges at 7 Hz a
#: pair: lag-one correlation 0.4-0.9 of the residuals), so a 7 Hz link does not give 7
#: times the evidence of a 1 Hz one
DECORRELATION_S = 1.0


@numba.njit(cache=True)
def _judge(fb: FaultBuffers, p: int, t: float, window: float, k0: float) -> float:
    """The variance per horizontal axis that a shift of platform ``p`` explaining its
    kept ranges calls for (module doc), 0 when none does."""
    n = fb.kept[p]
    sel, key, wt = fb.work_i, fb.work_f[0], fb.work_f[1]
    m = 0
    for i in range(n):
        q = fb.partner[p, i]
        if q >= 0 and fb.last_jump[q] >= t - window:
            continue  # the partner's own jump explains these (it was judged first)
        if fb.t[p, i] >= t - window:
            # the ranges by partner, then time (partners' keys apart by more than the
            # window); an insertion sort of at most CAPACITY, kept sorted as it fills
            k_new = q * (window + 10.0) + (fb.t[p, i] - t + window)
            j = m
            while j > 0 and key[j - 1] > k_new:
                key[j] = key[j - 1]
                sel[j] = sel[j - 1]
                j -= 1
            key[j] = k_new
            sel[j] = i
            m += 1
    if m == 0:
        return 0.0
    # each range's weight, a partner's ranges within one DECORRELATION_S counting as one
    # (module doc), and the partners whose ranges are off on their own
    n_partners = 0
    n_off = 0
    start = 0
    while start < m:
        q = fb.partner[p, sel[start]]
        end = start
        n_slots = 0
        last_slot = -(2**62)
        while end < m and fb.partner[p, sel[end]] == q:
            slot = int(np.floor(fb.t[p, sel[end]] / DECORRELATION_S))
            if slot != last_slot:
                n_slots += 1
                last_slot = slot
            end += 1
        share = n_slots / (end - start)
        sw = swv = 0.0
        for j in range(start, end):
            wt[j] = share / (fb.scale[p, sel[j]] * fb.scale[p, sel[j]])
            sw += wt[j]
            swv += wt[j] * fb.v[p, sel[j]]
        n_partners += 1
        if abs(swv) / np.sqrt(sw) >= k0:
            n_off += 1
        start = end
    if n_partners < 3 or n_off < 2:
        # three partners fix a shift; one pair's excess is its own (NLOS), not the
        # platform's
        return 0.0
    a00 = a01 = a11 = b0 = b1 = 0.0
    for i in range(m):
        s = sel[i]
        w2 = wt[i]
        ju, jn = fb.jac[p, s, 0], fb.jac[p, s, 1]
        a00 += w2 * ju * ju
        a01 += w2 * ju * jn
        a11 += w2 * jn * jn
        b0 += w2 * ju * fb.v[p, s]
        b1 += w2 * jn * fb.v[p, s]
    det = a00 * a11 - a01 * a01
    if not det > 1e-12 * max(a00 * a11, 1e-300):
        return 0.0  # the partners' directions do not fix a 2-D shift
    du = (a11 * b0 - a01 * b1) / det
    dn = (a00 * b1 - a01 * b0) / det
    if du * b0 + dn * b1 < JUMP_CHI2:
        return 0.0
    for i in range(m):
        s = sel[i]
        post = fb.v[p, s] - fb.jac[p, s, 0] * du - fb.jac[p, s, 1] * dn
        if not abs(post) < k0 * fb.unit[p, s]:
            return 0.0
    return du * du + dn * dn


@numba.njit(cache=True)
def judge_epoch(
    fb: FaultBuffers,
    k: int,
    t: float,
    lo: int,
    m: int,
    obs: Observations,
    work: EpochWork,
    innov: FloatArray,
    scale: FloatArray,
    unit: FloatArray,
    fixed: np.ndarray,
    window: float,
    k0: float,
) -> None:
    """Keep epoch ``k``'s ranges (time ``t``, observations ``lo:lo + m``: their Jacobians in
    ``work``, innovations at the prior ``innov`` (M,), standardizing sigmas ``scale`` and
    ``unit`` (m,), with and without the MAD factor) and judge each platform that is an end
    of them except the leaders (``fixed``; module doc); a jump found is left in ``fb.pending``
    for the filter to give at epoch ``k + 1`` (:func:`take_jumps`)."""
    for j in range(m):
        kind = obs.kind[lo + j]
        if kind == OBS_POSITION:
            continue
        a = obs.a[lo + j]
        ju, jn = work.h_val[j, 0], work.h_val[j, 1]
        if kind == OBS_RANGE:
            b = obs.b[lo + j]
            if not fixed[a]:
                _push(fb, a, t, b, ju, jn, innov[lo + j], scale[j], unit[j])
            if not fixed[b]:
                _push(fb, b, t, a, -ju, -jn, innov[lo + j], scale[j], unit[j])
        elif kind == OBS_ANCHOR and not fixed[a]:
            _push(fb, a, t, -1 - obs.anchor[lo + j], ju, jn, innov[lo + j], scale[j], unit[j])
    for j in range(m):
        if obs.kind[lo + j] == OBS_POSITION:
            continue
        for end in range(2):
            if end == 1 and obs.kind[lo + j] != OBS_RANGE:
                break
            p = obs.a[lo + j] if end == 0 else obs.b[lo + j]
            if fixed[p] or fb.pending[p] > 0.0 or t < fb.next_judged[p]:
                continue
            # once a DECORRELATION_S: the evidence changes by one piece a partner
            fb.next_judged[p] = t + DECORRELATION_S
            var = _judge(fb, p, t, window, k0)
            if var > 0.0:
                fb.pending[p] = var
                fb.last_jump[p] = t
                fb.kept[p] = 0
                fb.head[p] = 0


#: the robust refit spreads a jump over this many fault windows before the epoch it was
#: found at (a slip is found when its evidence is complete, near or after its end)
SPREAD_WINDOWS = 2.0


def spread_jumps(proc: Process, epochs: FloatArray, window: float) -> Process:
    """``proc`` with each jump's variance spread evenly over the epochs of the
    :data:`SPREAD_WINDOWS` fault windows up to the one it was given at (a random walk of
    that total variance: a slip's error grows over its seconds, which the forward filter
    can only give once it has seen them)."""
    if proc.jump_k.shape[0] == 0:
        return proc
    ks: list[np.ndarray] = []
    ps: list[np.ndarray] = []
    vs: list[np.ndarray] = []
    for k, p, var in zip(proc.jump_k, proc.jump_p, proc.jump_var, strict=True):
        k0 = int(np.searchsorted(epochs, epochs[k] - SPREAD_WINDOWS * window))
        span = np.arange(max(k0, 1), k + 1, dtype=np.int64)
        ks.append(span)
        ps.append(np.full(span.shape[0], p, np.int64))
        vs.append(np.full(span.shape[0], var / span.shape[0]))
    k_all = np.concatenate(ks)
    order = np.argsort(k_all, kind="stable")
    return proc._replace(
        jump_k=k_all[order], jump_p=np.concatenate(ps)[order], jump_var=np.concatenate(vs)[order]
    )


@numba.njit(cache=True)
def take_jumps(
    fb: FaultBuffers, k: int, jump_k: IntArray, jump_p: IntArray, jump_var: FloatArray, n: int
) -> tuple[IntArray, IntArray, FloatArray, int]:
    """Append the jumps ``fb.pending`` holds, given at epoch ``k``, to the first ``n`` of
    ``jump_k``, ``jump_p``, ``jump_var`` (grown by doubling when full), and clear them."""
    for p in range(fb.pending.shape[0]):
        if fb.pending[p] > 0.0:
            if n == jump_k.shape[0]:
                size = max(2 * n, 16)
                grown_k = np.zeros(size, np.int64)
                grown_p = np.zeros(size, np.int64)
                grown_v = np.zeros(size)
                grown_k[:n] = jump_k[:n]
                grown_p[:n] = jump_p[:n]
                grown_v[:n] = jump_var[:n]
                jump_k, jump_p, jump_var = grown_k, grown_p, grown_v
            jump_k[n] = k
            jump_p[n] = p
            jump_var[n] = fb.pending[p]
            n += 1
            fb.pending[p] = 0.0
    return jump_k, jump_p, jump_var, n


#: the columns of a fusion's jumps table (FusionOutput.dr_jumps)
JUMP_COLUMNS = ("time", "platform", "size_m")


def jumps_table(moving: list[str], epochs: FloatArray, proc: Process) -> pd.DataFrame:
    """The jumps the forward filter gave (``proc``'s, before any spreading): the epoch's
    time, the platform and the fitted shift's length (m)."""
    return pd.DataFrame(
        {
            "time": epochs[proc.jump_k],
            "platform": [moving[p] for p in proc.jump_p],
            "size_m": np.sqrt(proc.jump_var),
        },
        columns=list(JUMP_COLUMNS),
    )


def jumps_of(table: pd.DataFrame | None) -> tuple[tuple[str, float, float], ...]:
    """A jumps table as (platform, time, size_m) tuples (FusionCalibration.dr_jumps)."""
    if table is None:
        return ()
    return tuple(
        (str(p), float(t), float(s))
        for t, p, s in table[list(JUMP_COLUMNS)].itertuples(index=False, name=None)
    )


#: the robust refit keeps a jump whose step in the smoothed solution is at least this
#: fraction of the shift the forward filter found (module doc)
CONFIRM_FRACTION = 0.5


def confirmed_jumps(
    proc: Process, epochs: FloatArray, nav: Navigation, slots: Slots, xs: FloatArray
) -> Process:
    """``proc`` with the jumps the smoothed solution ``xs`` (at the recorded ``slots``)
    confirms, each given the variance of its smoothed step or of the shift found, whichever
    is larger. The step is the change of the platform's
    correction (smoothed position minus navigation) from its last recorded epoch before
    the jump to its first at or after it. A wheel slip leaves a step of the size the
    forward filter found or larger (its error kept growing after it was found); a forward
    filter that was behind its ranges (a fast heading drift) leaves a smoothed solution
    without a step, and the jump would only cost the smoother the dead reckoning's
    continuity there (real ``plaza2``: steps 0.29-0.50 m for shifts of 1.1-1.6 m found,
    against 0.5-4 times the shift on the simulated slips of ``dr-faults``)."""
    if proc.jump_k.shape[0] == 0:
        return proc
    rec_epoch = np.repeat(np.arange(slots.ptr.shape[0] - 1), np.diff(slots.ptr))
    keep = np.zeros(proc.jump_k.shape[0], dtype=bool)
    var = proc.jump_var.copy()
    for j, (k, p) in enumerate(zip(proc.jump_k, proc.jump_p, strict=True)):
        rows = np.flatnonzero(slots.plat == p)
        at = int(np.searchsorted(rec_epoch[rows], k))
        if at == 0 or at >= rows.shape[0]:
            continue
        before, after = rows[at - 1], rows[at]
        t_nav, v_nav = nav.t[nav.ptr[p] : nav.ptr[p + 1]], nav.v[nav.ptr[p] : nav.ptr[p + 1]]
        step = 0.0
        for ax in range(2):
            moved = np.interp(epochs[rec_epoch[after]], t_nav, v_nav[:, ax]) - np.interp(
                epochs[rec_epoch[before]], t_nav, v_nav[:, ax]
            )
            step += (xs[after, ax] - xs[before, ax] - moved) ** 2
        keep[j] = step >= CONFIRM_FRACTION**2 * proc.jump_var[j]
        var[j] = max(step, proc.jump_var[j])
    return proc._replace(jump_k=proc.jump_k[keep], jump_p=proc.jump_p[keep], jump_var=var[keep])
