"""The distance filter run forward and backward in time, and the two runs combined.

Post-processing has the whole series, so the DI-Based distance filter (paper 000 eq. (8)-(12))
runs twice: forward, as the paper runs it in real time, and on the time-reversed series (the
ranges reversed, the DIs reversed and negated). An epoch is NLOS when both runs flag it,
or when it lies between a confirmed event's joint epochs and one run's own detection
(:func:`~coopproc.stages.ranging.onerun.trusted_edges`).

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
summed increments step there, and a DI event one run alone saw is kept when that level
series confirms it (:mod:`coopproc.stages.ranging.onerun`).

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
from coopproc.stages.ranging.nlos import (
    DistanceFilterOutput,
    EpochNoise,
    KernelParams,
    filter_distance,
)
from coopproc.stages.ranging.onerun import (
    events,
    lone_events,
    runs,
    trusted_edges,
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
    for first, end in events(event >= 0, event):
        last = end - 1
        parts = []
        j = fwd_first.get(int(fwd.event[first]), -1)
        if j >= 0 and time_s[first] - time_s[j] <= near_s:
            parts.append(float(fwd.nlos_estimate_m[first]))
        j = bwd_last.get(int(bwd_event[last]), -1)
        if j >= 0 and time_s[j] - time_s[last] <= near_s:
            parts.append(float(bwd_est[last]))
        value = float(np.mean(parts)) if parts else float(fwd.nlos_estimate_m[first])
        out[first:end] = value
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
    n = time_s.shape[0]
    bwd_d = rev.distance_m[::-1]
    bwd_flag = rev.nlos_flag[::-1].astype(bool)
    fwd_flag = fwd.nlos_flag.astype(bool)
    both = fwd_flag & bwd_flag
    distance = np.where(
        fwd_flag == bwd_flag,
        0.5 * (fwd.distance_m + bwd_d),
        np.where(fwd_flag, bwd_d, fwd.distance_m),
    )
    event = np.full(n, -1, dtype=np.int64)
    # a combined event is a run of epochs flagged by both, split where the forward run
    # restarted (event numbers of the forward run change)
    for number, (lo, hi) in enumerate(events(both, fwd.event)):
        event[lo:hi] = number
    # the ranges less the motion the increments model (the DI summed): line of sight is
    # a slow drift there, NLOS a level shift, whichever way the platforms move
    level = range_m - np.cumsum(np.nan_to_num(di_m, nan=0.0, posinf=0.0, neginf=0.0))
    fwd_only, bwd_only = trusted_edges(time_s, level, both, fwd, rev, params)
    distance = np.where(fwd_only, fwd.distance_m, np.where(bwd_only, bwd_d, distance))
    # the added epochs join the joint event they lead into (forward) or follow (backward)
    for lo, hi in runs(fwd_only):
        event[lo:hi] = event[hi] if hi < n else -1
    for lo, hi in runs(bwd_only):
        event[lo:hi] = event[lo - 1] if lo > 0 else -1
    flag = both | fwd_only | bwd_only
    # gamma_max of eq. (9) per epoch, as the kernel takes it (nlos_kernel.py)
    detect = noise.detect_sigma_m if noise is not None else np.full(n, params.detect_sigma_m)
    gamma = params.gamma_sigma * np.where(detect > 0.0, detect, fwd.sigma_m)
    bwd_est = rev.nlos_estimate_m[::-1]
    fwd_alone = lone_events(
        time_s, level, flag, (fwd_flag, fwd.event, fwd.nlos_estimate_m), bwd_flag, gamma, params
    )
    bwd_alone = lone_events(
        time_s, level, flag, (bwd_flag, rev.event[::-1], bwd_est), fwd_flag, gamma, params
    )
    for a, b in fwd_alone:
        distance[a:b] = fwd.distance_m[a:b]
    for a, b in bwd_alone:
        distance[a:b] = bwd_d[a:b]
    for a, b in fwd_alone + bwd_alone:
        flag[a:b] = True
        event[a:b] = event.max() + 1
    if fwd_alone or bwd_alone:
        # event numbers in time order again
        ids, first = np.unique(event[event >= 0], return_index=True)
        rank = np.empty(ids.shape[0], dtype=np.int64)
        rank[np.argsort(first)] = np.arange(ids.shape[0])
        event[event >= 0] = rank[np.searchsorted(ids, event[event >= 0])]
    estimate = np.where(flag, fwd.nlos_estimate_m, 0.0)
    for lo, hi in runs(bwd_only):
        # the forward run's estimate, held (eq. (12)) past where it stopped flagging
        estimate[lo:hi] = estimate[lo - 1] if lo > 0 else 0.0
    for a, b in bwd_alone:
        estimate[a:b] = bwd_est[a]  # the backward run's final one (its last epoch run)
    if params.one_shot:
        estimate = _one_shot_estimates(time_s, event, fwd, rev, params.window_s)
    step = np.where(flag & ~bwd_only, fwd.step_estimate_m, np.nan)
    for a, b in bwd_alone:
        step[a:b] = np.nan
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
