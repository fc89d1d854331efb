"""The fusion's observations: ranges between platforms and to anchors, leaders' own fixes.

Flat arrays in epoch order for the compiled filter (:mod:`coopproc.stages.fusion.ekf`),
with the epoch pointers ``ptr``.

A leader's own navigation enters as a fix of its position (``[fusion] leader_fix``):

- ``"epoch"``: at every epoch. With staggered polling the epochs are the range times (45
  per second for 10 platforms, 190 for 20), so a 10 Hz GNSS/INS fix is repeated 4.5-19
  times and weighs that much more than its sigma says: the leader is pinned to its
  navigation, and two of every three scalar updates are the leader's;
- ``"pooled"`` (default): the same information in one update per nav sample: at the
  first epoch at or after each nav time (and at the first epoch), with variance
  sigma^2 / m, m the epochs from there to the next such epoch (the fixes ``"epoch"``
  applies there; :func:`pooled_counts`). Where the nav is at least as fast as the ranges
  every epoch has its fix and m = 1: ``"epoch"`` bit for bit;
- ``"nav"``: once per navigation sample as ``"pooled"`` places it, with its own sigma.

Either way only at the epochs inside the leader's navigation span (issue 29, module
:mod:`~coopproc.stages.fusion.nav_span`): "the first epoch" is the first one inside it.

``"nav"`` is the consistent model, but the drift self-calibration (NIS per platform,
:mod:`coopproc.stages.fusion.calibration`) was tuned with a pinned leader: with ``"nav"``
part of each follower's innovation is attributed to the leader's uncertainty, its drift
is inflated less, and on the ``dr-faults`` scenario the followers' mean errors grow from
0.14-0.16 m to 0.22-0.33 m (sample_logs: 0.2 % better). ``"pooled"`` keeps the pinned
leader at a third of the scalar updates with many pairs (docs/methods-fusion.md, "The
leader's fix").
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from coopproc.model import FloatArray, Session
from coopproc.stages.fusion.ekf import OBS_ANCHOR, OBS_POSITION, OBS_RANGE
from coopproc.stages.fusion.nav_span import epoch_bounds, span_clip
from coopproc.stages.fusion.params import FusionParams
from coopproc.stages.shared.data import RangeRows, nav_points

__all__ = ["build_observations", "leader_fix_epochs", "nav_sigma"]


def leader_fix_epochs(
    session: Session, leaders: list[str], epochs: FloatArray, every_epoch: bool
) -> np.ndarray:
    """(L, K) bool: the epochs at which each leader's own fix is an observation, all
    inside the leader's navigation span (issue 29: none outside it)."""
    k_lo, k_hi = epoch_bounds(session, leaders, epochs)
    out = np.zeros((len(leaders), epochs.shape[0]), dtype=bool)
    for j, pid in enumerate(leaders):
        if k_lo[j] >= k_hi[j]:
            continue
        if every_epoch:
            out[j, k_lo[j] : k_hi[j]] = True
            continue
        at = np.searchsorted(epochs, session.nav[pid].time_s, side="left")
        out[j, at[at < k_hi[j]]] = True
        out[j, k_lo[j]] = True  # the first epoch inside its span
    return out


def pooled_counts(fixes: np.ndarray, k_hi: int) -> np.ndarray:
    """For ``leader_fix = "pooled"``: each fix epoch of one leader (``fixes``, K bool, as
    ``"nav"`` places them) with the number of epochs it stands for, from it up to the next
    fix epoch (the last: up to ``k_hi``, the end of the leader's span): the fixes that
    ``"epoch"`` would apply there, pooled into one (int64, one per fix epoch)."""
    return np.diff(np.append(np.flatnonzero(fixes), k_hi))  # every fix epoch is < k_hi


def nav_sigma(session: Session, pid: str, times: FloatArray, default_m: float) -> FloatArray:
    """1-sigma (K, 3) of a platform's own nav at ``times``: its sigma columns, else default."""
    traj = session.nav[pid]
    out = np.full((times.shape[0], 3), default_m)
    if traj.sigma_enu_m is not None:
        for axis in range(3):
            col = traj.sigma_enu_m[:, axis]
            good = np.isfinite(col) & (col > 0)
            if good.any():
                out[:, axis] = np.interp(times, traj.time_s[good], col[good])
    return out


def _lookup(ids: tuple[str, ...], order: list[str]) -> np.ndarray:
    """Position in ``order`` of each of ``ids`` (-1 where absent)."""
    where = {pid: i for i, pid in enumerate(order)}
    return np.array([where.get(pid, -1) for pid in ids], dtype=np.int64)


def _row_heights(
    session: Session, moving: list[str], plat: np.ndarray, epochs: FloatArray, ep_idx: np.ndarray
) -> FloatArray:
    """Height (m) of platform ``moving[plat[i]]``'s navigation at epoch ``ep_idx[i]`` of each
    row (0 where ``plat`` is -1): what (P, K, 3) navigation at the epochs holds there."""
    out = np.zeros(plat.shape[0])
    for p, pid in enumerate(moving):
        sel = np.flatnonzero(plat == p)
        if sel.size:  # (a merged epoch may open before the platform's span: its first sample)
            at = span_clip(session, pid, epochs[ep_idx[sel]])
            out[sel] = nav_points(session, pid, at, range(2, 3))[:, 0]
    return out


def build_observations(
    session: Session,
    rows: RangeRows,
    ep_idx: np.ndarray,
    epochs: FloatArray,
    moving: list[str],
    anchors: Mapping[str, FloatArray],
    params: FusionParams,
) -> dict[str, np.ndarray]:
    """Flat observation arrays in epoch order and the epoch pointers ``ptr`` (K + 1).

    A leader's fix is its navigation at the epoch (:func:`nav_points`). Codes are
    int8/int32; ``anchor`` is a row of ``anchor_table`` (T, 3), the fixed point or offset
    of the range (module :mod:`~coopproc.stages.fusion.ekf`), the last row zeros.
    """
    dim = params.dims
    index = {pid: i for i, pid in enumerate(moving)}
    to_moving_code = _lookup(rows.ids, moving)
    a_from = to_moving_code[rows.from_code]
    a_to = to_moving_code[rows.to_code]
    from_moving = a_from >= 0
    to_moving = a_to >= 0
    both = from_moving & to_moving
    a = np.where(from_moving, a_from, a_to).astype(np.int32)
    b = np.where(both, a_to, -1).astype(np.int32)
    anchor_ids = sorted(anchors)
    anchor_table = np.array([anchors[k] for k in anchor_ids] + [np.zeros(3)])
    to_anchor_code = _lookup(rows.ids, anchor_ids)
    anchor_code = to_anchor_code[np.where(from_moving, rows.to_code, rows.from_code)]
    del a_from, a_to, from_moving, to_moving
    anchor_code = np.where(anchor_code >= 0, anchor_code, len(anchor_ids)).astype(np.int32)
    row_t = rows.time
    late = np.flatnonzero(row_t != epochs[ep_idx])
    if late.size:  # ranges after their (merged) epoch time: carry the DR motion to them
        anchor = anchor_table[anchor_code]
        motion = np.zeros((len(rows), 2, 3))
        for p, pid in enumerate(moving):
            for end, ids in ((0, a), (1, b)):
                sel = late[ids[late] == p]
                if sel.size:
                    at_row = session.nav[pid].interpolate(row_t[sel])
                    # from the navigation the state carries at the epoch: a merged epoch
                    # before the platform's span carries its first sample (nav_span.py)
                    at_epoch = span_clip(session, pid, epochs[ep_idx[sel]])
                    motion[sel, end] = at_row - nav_points(session, pid, at_epoch, range(3))
        # OBS_RANGE: |X_a + m_a - X_b - m_b| = |X_a - X_b - (m_b - m_a)|;
        # OBS_ANCHOR: |X_a + m_a - anchor| = |X_a - (anchor - m_a)|
        anchor = np.where(both[:, None], motion[:, 1] - motion[:, 0], anchor - motion[:, 0])
        # each range row its own point (a table row), the last row zeros
        anchor_table = np.concatenate((anchor, np.zeros((1, 3))))
        anchor_code = np.arange(len(rows), dtype=np.int32)
        del anchor, motion
    if dim == 2:  # the heights from the navigation (``nav`` holds east/north only)
        up_a = _row_heights(session, moving, a, epochs, ep_idx)
        up_b = np.where(
            both, _row_heights(session, moving, b, epochs, ep_idx), anchor_table[anchor_code, 2]
        )
        dz2 = (up_a - up_b) ** 2
        del up_a, up_b
    else:
        dz2 = np.zeros(len(rows))
    # layout in epoch order: each epoch's leader fixes, then its ranges (rows are sorted)
    n_ep = epochs.shape[0]
    leaders = [pid for pid in moving if session.platforms[pid].role == "leader"]
    fixes = leader_fix_epochs(session, leaders, epochs, params.leader_fix == "epoch")
    _, k_hi = epoch_bounds(session, leaders, epochs)
    n_fix = fixes.sum(axis=0).astype(np.int64) * dim  # leader fix values per epoch
    counts = np.bincount(ep_idx, minlength=n_ep) + n_fix
    ptr = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    total = int(ptr[-1])
    first_row = np.searchsorted(ep_idx, np.arange(n_ep))
    at = ptr[ep_idx] + n_fix[ep_idx] + (np.arange(len(rows)) - first_row[ep_idx])
    # the codes in the narrowest dtype that holds them: only the compiled filter reads them
    obs: dict[str, np.ndarray] = {
        "kind": np.full(total, OBS_POSITION, dtype=np.int8),
        "a": np.zeros(total, dtype=np.int32),
        "b": np.zeros(total, dtype=np.int32),
        "anchor": np.full(total, anchor_table.shape[0] - 1, dtype=np.int32),  # zeros row
        "dz2": np.zeros(total),
        "z": np.zeros(total),
        "var": np.ones(total),
    }
    obs["kind"][at] = np.where(both, OBS_RANGE, OBS_ANCHOR)
    obs["a"][at] = a
    obs["b"][at] = b
    obs["anchor"][at] = anchor_code
    obs["anchor_table"] = anchor_table
    obs["dz2"][at] = dz2
    obs["z"][at] = rows.range
    obs["var"][at] = rows.var
    obs["at"] = at  # where each range row is, in row order
    del a, b, both, anchor_code, dz2, first_row, counts  # memory (issue 11): spent
    earlier = np.cumsum(fixes, axis=0) - fixes  # fixing leaders before this one, per epoch
    for j, pid in enumerate(leaders):
        ks = np.flatnonzero(fixes[j])
        sig = nav_sigma(session, pid, epochs[ks], params.leader_sigma_m)
        own = nav_points(session, pid, epochs[ks], range(dim))
        if params.leader_fix == "pooled":  # the information of the epochs it stands for
            sig = sig / np.sqrt(pooled_counts(fixes[j], int(k_hi[j])))[:, None]
        for axis in range(dim):
            slot = ptr[ks] + earlier[j, ks] * dim + axis
            obs["a"][slot] = index[pid]
            obs["b"][slot] = axis
            obs["z"][slot] = own[:, axis]
            obs["var"][slot] = sig[:, axis] ** 2
    obs["ptr"] = ptr
    return obs
