"""The distance filter run forward and backward in time, and the two runs combined.

Post-processing has the whole series, so the DI-Based distance filter (paper 000 eq. (8)-(12))
runs twice: forward, as the paper runs it in real time, and on the time-reversed series (the
ranges reversed, the DIs reversed and negated). An epoch is NLOS when both runs flag it,
or when it lies between a confirmed event's joint epochs and one run's own detection
(:func:`_trusted_edges`).

Why: on real recordings NLOS often fades in and out over a second or more instead of
switching. A forward run that holds its estimate (eq. (12)) updates the distance with
L - eps_hat, which agrees with itself whatever eps_hat is, so a gradual end of the
obstruction is followed instead of detected and the estimate is held on line-of-sight ranges
(measured on the real TIERS session: 277 of 436 line-of-sight epochs of tb1-tb3 flagged,
DI RMSE 2.5 x the observed). Run backward, the same span starts where the forward run saw it
end: its onset is caught there and the event ends where the forward one began. Each run's
false holds lie after its own detection, so the two do not agree on them; real events are
seen by both.

Each run is right where it detects, though, and the both-rule loses what one run catches
alone at its own edge of a confirmed event: where the forward DI run ended an event early
(a noisy leader's DI, the excess dipping) the backward run flags the rest of it up to its
own detection at the event's end; where the RN run absorbed a ramp-shaped onset one way,
the other way's detection covers it. Those epochs are added when the ranges less the
summed increments step there (:func:`_trusted_edges`). An RN event whose two runs each
saw one end and lost it before they met is joined up when the level series stays lifted
between them (:func:`_facing_events`).

The combined distance: the mean of the two runs where they agree on the epoch's state, the
run that sees line of sight where they do not, the flagging run's on the added epochs. The
DI-Based NLOS estimate (eq. (10)-(12)) and its running values (paper 000 fig. 10) are the
forward run's, kept inside the combined events (held over the epochs the backward run
added): the backward run confirms and extends where they are. The RN-Based estimate is the
mean of the two runs' one-shot estimates (:func:`_one_shot_estimates`): each run estimates
once, at its own detection (the forward one at the onset, the backward one at the end), so
two independent single-epoch residuals instead of one.
"""

from __future__ import annotations

import numpy as np

from coopproc.model import FloatArray
from coopproc.stages.ranging.jump import JUMP_MIN_POINTS, range_jump
from coopproc.stages.ranging.nlos import (
    DistanceFilterOutput,
    EpochNoise,
    KernelParams,
    filter_distance,
)

__all__ = ["filter_distance_two_way", "reverse_increments"]


def reverse_increments(values: FloatArray, negate: bool) -> FloatArray:
    """A per-interval series (row k: from epoch k-1 to k; row 0 unused) on reversed epochs.

    Reversed epoch j is original epoch n-1-j, so its interval from j-1 to j is the original
    interval n-j: row j of the result is row n-j of ``values`` (negated for increments,
    as is for variances); row 0 is NaN.
    """
    out = np.full(values.shape[0], np.nan)
    out[1:] = values[:0:-1]
    return -out if negate else out


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges of the consecutive True runs of ``flag``."""
    edges = np.diff(np.concatenate(([0], flag.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _events(flag: np.ndarray, ids: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) ranges of a run's events: its flagged runs, split where its event
    number changes."""
    out = []
    for lo, hi in _runs(flag):
        cuts = np.flatnonzero(np.diff(ids[lo:hi]) != 0) + 1
        out += [
            (lo + a, lo + b)
            for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), hi - lo], strict=True)
        ]
    return out


def _steps_more(
    time_s: FloatArray,
    level_m: FloatArray,
    k: int,
    other: int,
    least_m: float,
    window_s: float,
    up: bool,
) -> bool:
    """True when the level series (:func:`range_jump` on it) steps at epoch ``k`` by at
    least ``least_m`` and by more than at epoch ``other``: up (an onset) or down (an end)."""
    sign = 1.0 if up else -1.0
    a, _ = range_jump(time_s, level_m, k, window_s)
    b, _ = range_jump(time_s, level_m, other, window_s)
    if not (np.isfinite(a) and np.isfinite(b)):
        return False
    return bool(sign * a >= least_m and sign * a > sign * b)


def _trusted_edges(
    time_s: FloatArray,
    level_m: FloatArray,
    both: np.ndarray,
    fwd: DistanceFilterOutput,
    rev: DistanceFilterOutput,
    params: KernelParams,
) -> tuple[np.ndarray, np.ndarray]:
    """Epochs added to the jointly flagged ones because one run's detection is trusted
    there: (forward-only, backward-only) masks.

    A run detects where it sees the residual jump; what it gets wrong is the far side of
    its event (a false hold after the detection, or an early end where it absorbed a
    ramp). So a backward event confirmed by the forward run is flagged from the last
    jointly flagged epoch to its own detection (its last epoch in forward time), and, for
    the RN method, a confirmed forward event from its detection (its first epoch) to the
    first jointly flagged epoch. Each extension must be backed by the ranges: the level
    series (``level_m``, the ranges less the summed increments) steps at the detection by
    at least ``jump_fraction`` times the run's estimate and by more than where the other
    run's event ended; otherwise the other run's edge is the real one (a forward false
    detection that held on into a later event) and the both-rule stands. Only the first
    joint epoch of a forward event (the last of a backward one) bounds an extension.
    """
    fwd_only = np.zeros(both.shape[0], dtype=bool)
    bwd_only = np.zeros(both.shape[0], dtype=bool)
    fraction, window = params.jump_fraction, params.jump_window_s
    if fraction <= 0.0:
        return fwd_only, bwd_only
    if params.one_shot:
        for lo, hi in _events(fwd.nlos_flag.astype(bool), fwd.event):
            joint = np.flatnonzero(both[lo:hi])
            if joint.size and joint[0] > 0:
                k = lo + int(joint[0])
                least = fraction * abs(float(fwd.nlos_estimate_m[k]))
                if _steps_more(time_s, level_m, lo, k, least, window, up=True):
                    fwd_only[lo:k] = True
    bwd_est = rev.nlos_estimate_m[::-1]
    for lo, hi in _events(rev.nlos_flag[::-1].astype(bool), rev.event[::-1]):
        joint = np.flatnonzero(both[lo:hi])
        if joint.size and lo + int(joint[-1]) + 1 < hi < both.shape[0]:
            k = lo + int(joint[-1]) + 1
            least = fraction * abs(float(bwd_est[k]))
            if _steps_more(time_s, level_m, hi, k, least, window, up=False):
                bwd_only[k:hi] = True
    return fwd_only & ~both, bwd_only & ~both & ~fwd_only


def _facing_events(
    time_s: FloatArray,
    level_m: FloatArray,
    both: np.ndarray,
    fwd: DistanceFilterOutput,
    rev: DistanceFilterOutput,
    params: KernelParams,
) -> list[tuple[int, int, int, int]]:
    """RN events seen from their two ends only: (fa, fb, ba, bb), a forward event [fa, fb)
    and the backward event [ba, bb) after it, neither overlapping anything jointly flagged,
    with no epoch between them flagged by either run.

    Each run detected one end and lost the event where the excess dipped, before the two
    met (``noisy-leader`` seed 13: forward 5 s from the onset, backward 18 s from the end,
    2 s apart). They are one event when the level series steps up at the forward
    detection and down at the backward one (by ``jump_fraction`` of each run's estimate)
    and stays lifted by as much between the two (:func:`_lift`): two separate events
    have line of sight there.
    """
    fraction, window = params.jump_fraction, params.jump_window_s
    if fraction <= 0.0 or not params.one_shot:
        return []
    n = both.shape[0]
    bwd_flag = rev.nlos_flag[::-1].astype(bool)
    fwd_flag = fwd.nlos_flag.astype(bool)
    bwd_est = rev.nlos_estimate_m[::-1]
    alone_b = [e for e in _events(bwd_flag, rev.event[::-1]) if not both[e[0] : e[1]].any()]
    out = []
    for fa, fb in _events(fwd_flag, fwd.event):
        if fa == 0 or both[fa:fb].any():
            continue
        later = [e for e in alone_b if e[0] >= fb]
        if not later:
            continue
        ba, bb = later[0]
        if bb >= n or (fwd_flag[fb:ba] | bwd_flag[fb:ba]).any():
            continue
        least_f = fraction * abs(float(fwd.nlos_estimate_m[fa]))
        least_b = fraction * abs(float(bwd_est[bb - 1]))
        j_fa = range_jump(time_s, level_m, fa, window)[0]
        j_bb = range_jump(time_s, level_m, bb, window)[0]
        lift = _lift(time_s, level_m, fa, bb, fb, ba, window)
        if j_fa >= least_f and -j_bb >= least_b and lift >= min(least_f, least_b):
            out.append((fa, fb, ba, bb))
    return out


def _lift(
    time_s: FloatArray, level_m: FloatArray, a: int, b: int, lo: int, hi: int, window_s: float
) -> float:
    """How far the level series lies above its line-of-sight course over epochs [lo, hi):
    the mean of ``level_m`` there less the line fitted to the epochs within ``window_s``
    (and at least :data:`JUMP_MIN_POINTS`) before ``a`` and from ``b`` on. NaN when a side
    has fewer than 2 finite values."""
    n = time_s.shape[0]
    before = np.arange(a)
    before = before[(time_s[a] - time_s[before] <= window_s) | (before >= a - JUMP_MIN_POINTS)]
    after = np.arange(b, n)
    after = after[(time_s[after] - time_s[b] < window_s) | (after < b + JUMP_MIN_POINTS)]
    sides = np.concatenate((before, after))
    sides = sides[np.isfinite(level_m[sides])]
    if np.count_nonzero(sides < a) < 2 or np.count_nonzero(sides >= b) < 2:
        return float("nan")
    gap = np.arange(lo, hi)
    gap = gap[np.isfinite(level_m[gap])]
    if not gap.size:
        return float("nan")
    slope, intercept = np.polyfit(time_s[sides] - time_s[a], level_m[sides], 1)
    course = intercept + slope * (time_s[gap] - time_s[a])
    return float(np.mean(level_m[gap] - course))


def _detections(event: np.ndarray, last: bool) -> dict[int, int]:
    """Event number -> the index of its first (``last``: final) epoch."""
    ids = event if not last else event[::-1]
    numbers, first = np.unique(ids, return_index=True)
    n = event.shape[0]
    return {
        int(e): (n - 1 - int(i) if last else int(i))
        for e, i in zip(numbers, first, strict=True)
        if e >= 0
    }


def _one_shot_estimates(
    time_s: FloatArray,
    event: np.ndarray,
    fwd: DistanceFilterOutput,
    rev: DistanceFilterOutput,
    near_s: float,
) -> FloatArray:
    """The RN-Based estimate of each combined event: the mean of the two runs' one-shot
    estimates (each taken at its own detection, paper 000 sec. 4.3 on ref. [2]: "only
    estimated NLOS once"), the forward run detecting at the onset and the backward one at
    the end, so two independent single-epoch residuals. A run's estimate counts only when
    its detection lies within ``near_s`` (the estimation window M) of the combined event
    (else that run was holding an estimate from elsewhere: a false hold the other run did
    not confirm); the forward one alone when neither does.
    """
    out = np.zeros(time_s.shape[0])
    bwd_event = rev.event[::-1]
    bwd_est = rev.nlos_estimate_m[::-1]
    fwd_first = _detections(fwd.event, last=False)
    bwd_last = _detections(bwd_event, last=True)
    for lo, hi in _runs(event >= 0):
        cuts = np.flatnonzero(np.diff(event[lo:hi]) != 0) + 1
        for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), hi - lo], strict=True):
            first, last = lo + a, lo + b - 1
            parts = []
            j = fwd_first.get(int(fwd.event[first]), -1)
            if j >= 0 and time_s[first] - time_s[j] <= near_s:
                parts.append(float(fwd.nlos_estimate_m[first]))
            j = bwd_last.get(int(bwd_event[last]), -1)
            if j >= 0 and time_s[j] - time_s[last] <= near_s:
                parts.append(float(bwd_est[last]))
            value = float(np.mean(parts)) if parts else float(fwd.nlos_estimate_m[first])
            out[first : last + 1] = value
    return out


def filter_distance_two_way(
    time_s: FloatArray,
    range_m: FloatArray,
    di_m: FloatArray,
    di_var_m2: FloatArray,
    params: KernelParams,
    noise: EpochNoise | None = None,
) -> tuple[DistanceFilterOutput, DistanceFilterOutput]:
    """(combined, forward) outputs of the distance filter (see the module docstring)."""
    fwd = filter_distance(time_s, range_m, di_m, di_var_m2, params, noise)
    rev = filter_distance(
        -time_s[::-1],
        range_m[::-1],
        reverse_increments(di_m, negate=True),
        reverse_increments(di_var_m2, negate=False),
        params,
        None if noise is None else noise.reversed(),
    )
    bwd_d = rev.distance_m[::-1]
    bwd_flag = rev.nlos_flag[::-1].astype(bool)
    fwd_flag = fwd.nlos_flag.astype(bool)
    both = fwd_flag & bwd_flag
    distance = np.where(
        fwd_flag == bwd_flag,
        0.5 * (fwd.distance_m + bwd_d),
        np.where(fwd_flag, bwd_d, fwd.distance_m),
    )
    event = np.full(time_s.shape[0], -1, dtype=np.int64)
    # a combined event is a run of epochs flagged by both, split where the forward run
    # restarted (event numbers of the forward run change)
    for number, (lo, hi) in enumerate(_events(both, fwd.event)):
        event[lo:hi] = number
    # the ranges less the motion the increments model (the DI summed): line of sight is
    # a slow drift there, NLOS a level shift, whichever way the platforms move
    level = range_m - np.cumsum(np.nan_to_num(di_m, nan=0.0, posinf=0.0, neginf=0.0))
    fwd_only, bwd_only = _trusted_edges(time_s, level, both, fwd, rev, params)
    distance = np.where(fwd_only, fwd.distance_m, np.where(bwd_only, bwd_d, distance))
    # the added epochs join the joint event they lead into (forward) or follow (backward)
    for lo, hi in _runs(fwd_only):
        event[lo:hi] = event[hi] if hi < event.shape[0] else -1
    for lo, hi in _runs(bwd_only):
        event[lo:hi] = event[lo - 1] if lo > 0 else -1
    flag = both | fwd_only | bwd_only
    facing = _facing_events(time_s, level, both, fwd, rev, params)
    for fa, fb, ba, bb in facing:
        flag[fa:bb] = True
        event[fa:bb] = event.max() + 1
        distance[fa:fb] = fwd.distance_m[fa:fb]
        distance[ba:bb] = bwd_d[ba:bb]
    if facing:
        # event numbers in time order again
        ids, first = np.unique(event[event >= 0], return_index=True)
        rank = np.empty(ids.shape[0], dtype=np.int64)
        rank[np.argsort(first)] = np.arange(ids.shape[0])
        event[event >= 0] = rank[np.searchsorted(ids, event[event >= 0])]
    estimate = np.where(flag, fwd.nlos_estimate_m, 0.0)
    for lo, hi in _runs(bwd_only):
        # the forward run's estimate, held (eq. (12)) past where it stopped flagging
        estimate[lo:hi] = estimate[lo - 1] if lo > 0 else 0.0
    if params.one_shot:
        estimate = _one_shot_estimates(time_s, event, fwd, rev, params.window_s)
        for _fa, fb, ba, _bb in facing:
            # where neither run flagged it: the ranges less the event's estimate
            distance[fb:ba] = range_m[fb:ba] - estimate[fb:ba]
    step = np.where(flag & ~bwd_only, fwd.step_estimate_m, np.nan)
    combined = DistanceFilterOutput(
        distance_m=distance,
        nlos_flag=flag.astype(np.int8),
        nlos_estimate_m=estimate,
        event=event,
        step_estimate_m=step,
        sigma_m=fwd.sigma_m,
        residual_m=fwd.residual_m,
    )
    return combined, fwd
