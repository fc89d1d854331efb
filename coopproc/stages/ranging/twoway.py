"""The distance filter run forward and backward in time, and the two runs combined.

Post-processing has the whole series, so the DI-Based distance filter (paper 000 eq. (8)-(12))
runs twice: forward, as the paper runs it in real time, and on the time-reversed series (the
ranges reversed, the DIs reversed and negated). An epoch is NLOS when both runs flag it.

Why: on real recordings NLOS often fades in and out over a second or more instead of
switching. A forward run that holds its estimate (eq. (12)) updates the distance with
L - eps_hat, which agrees with itself whatever eps_hat is, so a gradual end of the
obstruction is followed instead of detected and the estimate is held on line-of-sight ranges
(measured on the real TIERS session: 277 of 436 line-of-sight epochs of tb1-tb3 flagged,
DI RMSE 2.5 x the observed). Run backward, the same span starts where the forward run saw it
end: its onset is caught there and the event ends where the forward one began. Each run's
false holds lie after its own detection, so the two do not agree on them; real events are
seen by both.

The combined distance: the mean of the two runs where they agree on the epoch's state, the
run that sees line of sight where they do not. The DI-Based NLOS estimate (eq. (10)-(12))
and its running values (paper 000 fig. 10) are the forward run's, kept inside the combined
events: the backward run only confirms where they are. The RN-Based estimate is the mean of
the two runs' one-shot estimates (:func:`_one_shot_estimates`): each run estimates once, at
its own detection (the forward one at the onset, the backward one at the end), so two
independent single-epoch residuals instead of one.
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
    estimate = np.where(both, fwd.nlos_estimate_m, 0.0)
    event = np.full(time_s.shape[0], -1, dtype=np.int64)
    # a combined event is a run of epochs flagged by both, split where the forward run
    # restarted (event numbers of the forward run change)
    number = 0
    for lo, hi in _runs(both):
        ids = fwd.event[lo:hi]
        cuts = np.flatnonzero(np.diff(ids) != 0) + 1
        for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), hi - lo], strict=True):
            event[lo + a : lo + b] = number
            number += 1
    if params.one_shot:
        estimate = _one_shot_estimates(time_s, event, fwd, rev, params.window_s)
    step = np.where(both, fwd.step_estimate_m, np.nan)
    combined = DistanceFilterOutput(
        distance_m=distance,
        nlos_flag=both.astype(np.int8),
        nlos_estimate_m=estimate,
        event=event,
        step_estimate_m=step,
        sigma_m=fwd.sigma_m,
        residual_m=fwd.residual_m,
    )
    return combined, fwd
