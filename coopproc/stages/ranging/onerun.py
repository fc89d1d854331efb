"""Epochs one run of the two-way distance filter flags alone, kept on the ranges' own
evidence (issue 30.5; docs/methods-ranging.md#forward-and-backward-two_way-twowaypy).

The both-rule of :mod:`coopproc.stages.ranging.twoway` (an epoch is NLOS where the forward
and the backward run both flag it) drops what one run caught alone. Each run is right where
it detects; it errs on the far side of its event. The evidence here is the *level series*,
the ranges less the summed increments: line of sight is a slow drift there, NLOS a level
shift, whichever way the platforms move. Two cases: a confirmed event's edge one run
alone flags (:func:`trusted_edges`), a DI event one run alone saw (:func:`lone_events`).
"""

from __future__ import annotations

import numpy as np

from coopproc.model import FloatArray
from coopproc.stages.ranging.jump import JUMP_MIN_POINTS, level_step
from coopproc.stages.ranging.nlos import DistanceFilterOutput, KernelParams

__all__ = ["LONE_EVIDENCE", "events", "lone_events", "runs", "trusted_edges"]


def runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges of the consecutive True runs of ``flag``."""
    edges = np.diff(np.concatenate(([0], flag.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def events(flag: np.ndarray, ids: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) ranges of a run's events: its flagged runs, split where its event
    number changes."""
    out = []
    for lo, hi in runs(flag):
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
    """True when the level series (:func:`~coopproc.stages.ranging.jump.level_step` on it:
    one range cannot make the step) steps at epoch ``k`` by at least ``least_m`` and by
    more than at epoch ``other``: up (an onset) or down (an end)."""
    sign = 1.0 if up else -1.0
    a, _ = level_step(time_s, level_m, k, window_s)
    b, _ = level_step(time_s, level_m, other, window_s)
    if not (np.isfinite(a) and np.isfinite(b)):
        return False
    return bool(sign * a >= least_m and sign * a > sign * b)


def trusted_edges(
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
    run's event ended (:func:`_steps_more`, one range cannot make that step), and lies
    above its line-of-sight course outside the run's event by as much over the extension
    (:func:`_lift`); otherwise the other run's edge is the real one (a forward false
    detection that held on into a later event, a hold that one long range started: real
    MiLUV at 0.8 Hz with a twice-drifting dead reckoning, a 46 s hold of 0.47 m on line
    of sight behind one range 1.4 m long) and the both-rule stands. Only the first
    joint epoch of a forward event (the last of a backward one) bounds an extension.
    """
    fwd_only = np.zeros(both.shape[0], dtype=bool)
    bwd_only = np.zeros(both.shape[0], dtype=bool)
    fraction, window = params.jump_fraction, params.jump_window_s
    if fraction <= 0.0:
        return fwd_only, bwd_only
    if params.one_shot:
        for lo, hi in events(fwd.nlos_flag.astype(bool), fwd.event):
            joint = np.flatnonzero(both[lo:hi])
            if joint.size and joint[0] > 0:
                k = lo + int(joint[0])
                least = fraction * abs(float(fwd.nlos_estimate_m[k]))
                if _steps_more(time_s, level_m, lo, k, least, window, up=True) and (
                    _lift(time_s, level_m, lo, hi, window, over=(lo, k)) >= least
                ):
                    fwd_only[lo:k] = True
    bwd_est = rev.nlos_estimate_m[::-1]
    for lo, hi in events(rev.nlos_flag[::-1].astype(bool), rev.event[::-1]):
        joint = np.flatnonzero(both[lo:hi])
        if joint.size and lo + int(joint[-1]) + 1 < hi < both.shape[0]:
            k = lo + int(joint[-1]) + 1
            least = fraction * abs(float(bwd_est[k]))
            if _steps_more(time_s, level_m, hi, k, least, window, up=False) and (
                _lift(time_s, level_m, lo, hi, window, over=(k, hi)) >= least
            ):
                bwd_only[k:hi] = True
    return fwd_only & ~both, bwd_only & ~both & ~fwd_only


#: A DI event one run alone saw (the other saw line of sight throughout) is kept when the
#: level series steps up at its start and down at its end, and lies above its
#: line-of-sight course between, each by at least this many gamma_max (eq. (9)) of the
#: pair. Measured on real TIERS (2026-12-07): with half the run's estimate alone a 36 s
#: tb4-tb7 hold of 0.16 m passed (64 % of that pair's line-of-sight epochs flagged), at
#: 1.0 and 1.25 a tb3-tb4 event flagged 33 % of its line-of-sight epochs; 1.5 and 2.0
#: give the same TIERS result (false alarms as without lone events); the simulated
#: handcart's missed 0.9 m event is kept at 1.5 (DI-fused 1.12 -> 1.04 x observed-fused),
#: less well at 2.0 (1.09 x).
LONE_EVIDENCE = 1.5


def _lift(
    time_s: FloatArray,
    level_m: FloatArray,
    a: int,
    b: int,
    window_s: float,
    over: tuple[int, int] | None = None,
) -> float:
    """How far the level series lies above its line-of-sight course over epochs [a, b):
    the mean of ``level_m`` there less the line fitted to the epochs within ``window_s``
    (and at least :data:`JUMP_MIN_POINTS`) before ``a`` and from ``b`` on. NaN when a side
    has fewer than 2 finite values. ``over``: the epochs [c, d) inside [a, b) averaged
    instead (an extension of an event, against the course outside the whole event)."""
    n = time_s.shape[0]
    if b >= n:  # no epoch after [a, b): no course
        return float("nan")
    before = np.arange(a)
    before = before[(time_s[a] - time_s[before] <= window_s) | (before >= a - JUMP_MIN_POINTS)]
    after = np.arange(b, n)
    after = after[(time_s[after] - time_s[b] < window_s) | (after < b + JUMP_MIN_POINTS)]
    sides = np.concatenate((before, after))
    sides = sides[np.isfinite(level_m[sides])]
    if np.count_nonzero(sides < a) < 2 or np.count_nonzero(sides >= b) < 2:
        return float("nan")
    gap = np.arange(a, b) if over is None else np.arange(over[0], over[1])
    gap = gap[np.isfinite(level_m[gap])]
    if not gap.size:
        return float("nan")
    slope, intercept = np.polyfit(time_s[sides] - time_s[a], level_m[sides], 1)
    course = intercept + slope * (time_s[gap] - time_s[a])
    return float(np.mean(level_m[gap] - course))


def lone_events(
    time_s: FloatArray,
    level_m: FloatArray,
    flag: np.ndarray,
    own: tuple[np.ndarray, np.ndarray, FloatArray],
    other_flag: np.ndarray,
    gamma_m: FloatArray,
    params: KernelParams,
) -> list[tuple[int, int]]:
    """[a, b) of the DI events of one run (``own``: its flags, event numbers and estimates
    in forward time) that nothing of the other run overlaps, kept by the level series.

    The both-rule drops them: one run caught the event, the other took it for a
    dead-reckoning fault (the range-step test on the ranges alone reads a bend of the
    motion as a step, docs/methods-ranging.md#range-step-test-range_jump) or absorbed it.
    A false hold has no step back down where it ends and a held estimate no lift; a
    wheel slip moves the level once and for good. So the level series must step up at
    ``a`` and down at ``b`` (:func:`~coopproc.stages.ranging.jump.level_step`) and lie
    above its course between (:func:`_lift`), each by at least :data:`LONE_EVIDENCE`
    gamma_max and by
    ``jump_fraction`` of the run's estimate.
    """
    fraction, window = params.jump_fraction, params.jump_window_s
    if fraction <= 0.0 or params.one_shot:
        return []
    own_flag, own_event, own_est = own
    n = flag.shape[0]
    out = []
    for a, b in events(own_flag, own_event):
        if a == 0 or b >= n or other_flag[a:b].any() or flag[a:b].any():
            continue
        least = max(fraction * abs(float(own_est[a])), LONE_EVIDENCE * float(gamma_m[a]))
        j_a = level_step(time_s, level_m, a, window)[0]
        j_b = level_step(time_s, level_m, b, window)[0]
        lift = _lift(time_s, level_m, a, b, window)
        if j_a >= least and -j_b >= least and lift >= least:
            out.append((a, b))
    return out
