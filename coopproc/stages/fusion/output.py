"""Fused states back to one Trajectory per platform, at the epochs or at the nav rate.

With staggered polling every range has its own epoch (45 per second for 10 platforms), and a
platform is reported and scored only at the epochs of its own ranges (paper 000's
cooperative updates; ``positions_at = "ranges"``). So the filter records each platform's
state only at the epochs where it can be asked for (:func:`recorded_slots`): those of its
ranges in the session and in the fused range set (dropouts included), the epochs either
side of any such time that falls between epochs, and the first and last epoch, so that
linear interpolation at those times gives exactly what the full trajectory would. That is
about 2/P of the states of P platforms at every epoch.

A platform is recorded, so reported, only at the epochs inside its own navigation span
(issue 29, :mod:`~coopproc.stages.fusion.nav_span`): "the first and last epoch" are its
first and last there, and at the nav rate its trajectory spans its navigation times
between them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.fusion.nav_span import epoch_bounds
from coopproc.stages.shared.data import nav_points, platform_codes

__all__ = [
    "recorded_slots",
    "solutions_from_slots",
    "trajectories_from_slots",
    "trajectory_at_nav_rate",
]


def recorded_slots(
    session: Session,
    ranges: pd.DataFrame,
    moving: list[str],
    epochs: FloatArray,
    record_all: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """CSR by epoch of the (epoch, platform) slots whose state the filter keeps.

    Returns ``rec_ptr`` (K + 1) and ``rec_plat`` (R): epoch k's slots are
    ``rec_plat[rec_ptr[k]:rec_ptr[k + 1]]``, platform indices into ``moving``, ascending.
    ``record_all``: every platform at every epoch (nav-rate output, merged epochs).
    Either way a platform only at the epochs inside its navigation span (issue 29,
    :mod:`~coopproc.stages.fusion.nav_span`): its first and last epoch are those inside it.
    """
    n_ep, n_plat = epochs.shape[0], len(moving)
    k_lo, k_hi = epoch_bounds(session, moving, epochs)
    everywhere = bool(np.all(k_lo <= 0) and np.all(k_hi >= n_ep))
    if record_all and everywhere:
        ptr = np.arange(n_ep + 1, dtype=np.int64) * n_plat
        return ptr, np.tile(np.arange(n_plat, dtype=np.int64), n_ep)
    wanted = np.zeros(n_ep * n_plat, dtype=bool)  # slot k * P + p
    if record_all:
        wanted[:] = True
        _outside_spans(wanted, k_lo, k_hi, n_ep)
        return _csr(wanted, n_ep, n_plat)
    for p in range(n_plat):  # each platform's first and last epoch inside its span
        if k_lo[p] < k_hi[p]:
            wanted[k_lo[p] * n_plat + p] = True
            wanted[(k_hi[p] - 1) * n_plat + p] = True
    frames = [session.ranges.frame]
    if not _same_rows(session.ranges.frame, ranges):  # (the observed set: the same slots)
        frames.append(ranges)
    for frame in frames:
        t = pd.to_numeric(frame["time"], errors="coerce").to_numpy(np.float64)
        good = np.isfinite(t)
        # one search: the epochs at or before t; those before t one fewer where t is one
        after = np.searchsorted(epochs, t, side="right")
        exact = epochs[np.maximum(after - 1, 0)] == t
        right = np.clip(after - 1, 0, n_ep - 1)
        left = np.clip(after - exact, 0, n_ep - 1)
        del after, exact
        for column in ("from", "to"):
            ids = frame[column]
            if not pd.api.types.is_string_dtype(ids):
                ids = ids.astype(str)
            code = platform_codes(ids, moving)
            sel = good & (code >= 0)
            wanted[right[sel] * n_plat + code[sel]] = True
            wanted[left[sel] * n_plat + code[sel]] = True
    if not everywhere:  # a platform is recorded inside its navigation span only
        _outside_spans(wanted, k_lo, k_hi, n_ep)
    return _csr(wanted, n_ep, n_plat)


def _outside_spans(wanted: np.ndarray, k_lo: np.ndarray, k_hi: np.ndarray, n_ep: int) -> None:
    """Clear each platform's slots before its first and after its last epoch inside its
    navigation span (slot k * P + p), in place."""
    n_plat = k_lo.shape[0]
    for p in range(n_plat):
        lo, hi = min(int(k_lo[p]), n_ep), max(int(k_hi[p]), 0)
        wanted[p : lo * n_plat : n_plat] = False
        wanted[hi * n_plat + p :: n_plat] = False


def _csr(wanted: np.ndarray, n_ep: int, n_plat: int) -> tuple[np.ndarray, np.ndarray]:
    """The wanted slots (k * P + p) as CSR by epoch: ``rec_ptr``, ``rec_plat``."""
    unique = np.flatnonzero(wanted)
    counts = np.bincount(unique // n_plat, minlength=n_ep)
    ptr = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    return ptr, (unique % n_plat).astype(np.int64)


def _same_rows(first: pd.DataFrame, second: pd.DataFrame) -> bool:
    """Whether two range tables have the same time, from and to columns, row by row."""
    if first is second:
        return True
    if len(first) != len(second):
        return False
    for column in ("time", "from", "to"):
        a, b = first[column], second[column]
        if a.dtype != b.dtype or not a.equals(b):
            return False
    return True


def trajectories_from_slots(
    session: Session,
    moving: list[str],
    epochs: FloatArray,
    rec_ptr: np.ndarray,
    rec_plat: np.ndarray,
    dim: int,
    output: str,
    xs: FloatArray,
    var: FloatArray | None,
    *,
    hold: bool,
) -> dict[str, Trajectory]:
    """One Trajectory per platform from the recorded slots' states and variances (R, dim).

    ``output="ranges"``: each platform at its recorded epochs; ``"nav"`` (every slot
    recorded): :func:`trajectory_at_nav_rate`. ``var`` None: no sigmas.
    """
    slots = (session, moving, epochs, rec_ptr, rec_plat, dim, output)
    return solutions_from_slots(*slots, [(xs, var, hold)])[0]


def solutions_from_slots(
    session: Session,
    moving: list[str],
    epochs: FloatArray,
    rec_ptr: np.ndarray,
    rec_plat: np.ndarray,
    dim: int,
    output: str,
    solutions: list[tuple[FloatArray, FloatArray | None, bool]],
) -> list[dict[str, Trajectory]]:
    """:func:`trajectories_from_slots` of several solutions (states, variances, hold) of
    the same slots (the forward and the smoothed): each platform's slots, epochs and
    navigation heights found once for all of them. ``solutions`` is consumed: each
    solution's arrays are let go as soon as its trajectories are built (memory, issue 11:
    the smoothed trajectories are built after the forward states are freed).

    Each platform's trajectory is made of its own slots only, so it spans the epochs
    inside its navigation span (:func:`recorded_slots`); ``output="nav"``: every slot of
    the platform there is recorded, :func:`trajectory_at_nav_rate`."""
    n_ep, n_plat = epochs.shape[0], len(moving)
    out: list[dict[str, Trajectory]] = []
    epoch_of: np.ndarray | None = np.repeat(np.arange(n_ep), np.diff(rec_ptr))
    # each platform's slots, ascending: a stable sort of small codes (radix sort)
    code = rec_plat.astype(np.int16 if n_plat < 2**15 else np.int64)
    by_plat = np.argsort(code, kind="stable")
    bounds = np.searchsorted(code[by_plat], np.arange(n_plat + 1))
    del code
    times_of: list[FloatArray] = []  # each platform's epochs and heights, from the first
    heights: list[FloatArray | None] = []
    while solutions:
        xs, var, hold = solutions.pop(0)
        found: dict[str, Trajectory] = {}
        for p, pid in enumerate(moving):
            slots = by_plat[bounds[p] : bounds[p + 1]]
            if epoch_of is not None:
                times = epochs[epoch_of[slots]]
                times_of.append(times)
                at_epochs = output == "ranges" and dim < 3 and slots.shape[0] > 0
                heights.append(
                    nav_points(session, pid, times, range(dim, 3)) if at_epochs else None
                )
            else:
                times = times_of[p].copy()
            if slots.shape[0] == 0:  # no epoch inside its navigation span: no trajectory
                continue
            if output != "ranges":
                sig_var = np.full((slots.shape[0], dim), np.nan) if var is None else var[slots]
                found[pid] = trajectory_at_nav_rate(
                    session, pid, times, xs[slots], sig_var, dim, hold=hold
                )
                continue
            enu = np.empty((slots.shape[0], 3))
            enu[:, :dim] = xs[slots]
            up = heights[p]
            if up is not None:  # the height: the platform's own navigation at those epochs
                enu[:, dim:] = up
            sig = None
            if var is not None:
                sig = np.full((slots.shape[0], 3), np.nan)
                sig[:, :dim] = np.sqrt(np.maximum(var[slots], 0.0))
            found[pid] = Trajectory(pid, times, enu, sigma_enu_m=sig, source="fusion")
        del xs, var
        epoch_of = None
        out.append(found)
    return out


def trajectory_at_nav_rate(
    session: Session,
    pid: str,
    epochs: FloatArray,
    est: FloatArray,
    var: FloatArray,
    dim: int,
    *,
    hold: bool,
) -> Trajectory:
    """``pid``'s trajectory at its navigation times between its first and last epoch
    (``epochs``, inside its navigation span; ``est`` / ``var`` its states and variances
    there, (n, dim)).

    The correction (fused minus nav) is carried between epochs: held from the last epoch
    for the causal ``forward`` solution, linearly interpolated for the smoothed.
    """
    sig = np.full((epochs.shape[0], 3), np.nan)
    sig[:, :dim] = np.sqrt(np.maximum(var, 0.0))
    traj = session.nav[pid]
    sel = (traj.time_s >= epochs[0]) & (traj.time_s <= epochs[-1])
    times = traj.time_s[sel]
    enu = traj.enu_m[sel].copy()
    corr = est - nav_points(session, pid, epochs, range(dim))
    if hold:
        k = np.clip(np.searchsorted(epochs, times, side="right") - 1, 0, None)
        enu[:, :dim] += corr[k]
        sig_t = sig[k]
    else:
        sig_t = np.full((times.shape[0], 3), np.nan)
        for axis in range(dim):
            enu[:, axis] += np.interp(times, epochs, corr[:, axis])
            sig_t[:, axis] = np.interp(times, epochs, sig[:, axis])
    return Trajectory(pid, times, enu, sigma_enu_m=sig_t, source="fusion")
