"""Geometry-aware least-squares fixes from anchors: the input of ``lsq``, ``lsq_kf``, ``lsq_rts``.

:mod:`coopproc.stages.shared.lsq` solves every epoch from the anchors' centroid and
writes whatever comes out. On real recordings (issue 31) that fails three ways: anchors
in a compact cluster seen from 50 m (hanyang_los: HDOP up to 29) give epochs with three
ranges whose horizontal problem has a *mirror* solution (three anchors whose horizontal
projections are collinear), so a fix flips by 40-90 m; a Gauss-Newton start at the
centroid lands on the wrong branch; and a tag without navigation was solved at a height
of 0 m whatever its real height. Here, per platform and epoch:

1. **Epochs** (the staggered-range rule): a platform's ranges in time order form rounds;
   a round closes when an anchor already in it is ranged again or ``round_max_s``
   after its first range (anchors polled one at a time: tuc's 4 modules in 0.38 s,
   miluv1's 6 anchors in 1.3 s; ``epoch_merge_s`` = 0.25 s, the fusion start's rule,
   gave tuc no fix). The round's time is its last range's time (positions.csv rows
   are at range epochs; the fix uses no later range); each earlier range is carried to
   it with the platform's velocity, ``|X(t_i) - a| = |X(t) - (a - v (t_i - t))|``, v
   from the constant-velocity RTS over a first pass of fixes (a raw fix difference at
   10 Hz and HDOP 29 is metres per second off, and one mirror flip is 450 m/s). A tag at
   walking speed with ranges 25 ms apart is not smeared
   (tests/stages/anchors/test_anchor_lsq.py).
2. **Height and dimension**: ``planar = false`` in session.toml (or ``[fusion.lsq] dims
   = 3`` for all) gives 3-D fixes (four anchors at least). A planar platform (the
   default, ``dims = 2``) is solved at one height: session.toml ``height``, else its
   navigation's height, else ``[fusion.lsq] tag_up_m``, else *estimated*: when the
   anchors span height (up spread >= 0.5 m and >= 20 % of their horizontal extent;
   hanyang_los: 1.47 m over 2.6 m), the median height of the 3-D fixes with the lowest
   ``NEAR_PERCENT`` % of VDOPs (far fixes are biased high, the range is not linear in
   the height there: in the test's walk from 10 to 50 m, true 1.0 m, all fixes give
   1.94 m, the nearest 10 % 1.36 m; hanyang_los 0.99 m and 1.02 m, its horizontal RMSE
   the same from 0.5 to 1.5 m); else the height whose fixes have the least median
   chi-square, searched from the anchors' plane down 3 m (0.25 m steps, then 0.05 m). A
   note names the height and where it came from; never a silent 0 m.
3. **Start**: the closed-form solution of the differenced squared ranges
   (r_i^2 - r_0^2 linear in X), then the robust Gauss-Newton of ``lsq``.
4. **Mirror guard**: the fix reflected across the plane (2-D: the line) that best fits
   the epoch's anchors is solved again; when both pass the residual test and lie more
   than 1 m apart the epoch is ambiguous and takes the solution nearer the unambiguous
   fixes (interpolated in time, up to ``mirror_window_s`` away), else it is dropped.
5. **Tests**: HDOP (and VDOP for 3-D) from the unit-weight design; the chi-square of
   the robustly weighted standardized residuals against its (1 - ``residual_alpha``)
   quantile with n - d degrees of freedom; a fix with HDOP > ``hdop_max`` or failing
   the test is dropped (status ``dop`` / ``residual``), as one that diverged. A fix with
   one redundant range (dof 1) has a test without power against a wrong branch: its
   bound is ``hdop_max_minimal`` (hanyang_los's 3-anchor epochs have HDOP 10-1800 and
   came out ok, dropped or diverged by 2 cm of assumed height: ``lsq_rts`` 0.68-0.77 m
   with every one of them, 0.63 m with those under 15). Every
   epoch and its decision goes to lsq_quality.csv (docs/outputs.md).

Measured on hanyang_los (LOS, 4 anchors in a 2.6 m cluster, 50 m path): raw fixes 0.76 m
2-D RMSE, ``lsq_rts`` 0.65 m, against 1,706 m mean error before.
"""

from __future__ import annotations

import contextvars
import dataclasses
import weakref
from collections.abc import Mapping
from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd

from coopproc.distributions import chi2_ppf
from coopproc.model import FloatArray, Session
from coopproc.names import LSQ_QUALITY_COLUMNS
from coopproc.stages.anchors.uwb_kf import cv_smooth
from coopproc.stages.base import PositionProduct
from coopproc.stages.shared.data import anchor_positions, clean_ranges, range_sigma_default
from coopproc.stages.shared.lsq import LsqFixes, LsqParams, _design, _gauss_newton

__all__ = ["AnchorSolution", "anchor_fixes", "lsq_quality_of"]

#: Candidate solutions closer than this (m) are one solution, not a mirror pair.
MIRROR_SEPARATION_M = 1.0
#: Fewest accepted 3-D fixes for an estimated height; the search over heights otherwise.
MIN_HEIGHT_FIXES = 10
#: The height is the median of the 3-D fixes with the lowest VDOPs, this percentage of them.
NEAR_PERCENT = 10.0
#: A fix farther than this from the anchors (m) beyond its longest range has diverged.
DIVERGED_MARGIN_M = 10.0


@dataclass(frozen=True, eq=False)
class AnchorSolution:
    """The accepted fixes by platform, every epoch's quality row, and the notes."""

    fixes: Mapping[str, LsqFixes]
    quality: pd.DataFrame  # LSQ_QUALITY_COLUMNS, method empty
    notes: tuple[str, ...]
    #: platform -> (d, epoch times, the height at them: used by the 2-D model only)
    geometry: Mapping[str, tuple[int, FloatArray, FloatArray]]


@dataclass(frozen=True, eq=False)
class _Rounds:
    """One platform's rounds as padded problems (E epochs, M slots)."""

    time: FloatArray  # (E,)
    pos: FloatArray  # (E, M, 3) anchor positions
    rng: FloatArray  # (E, M)
    var: FloatArray  # (E, M)
    has: np.ndarray  # (E, M) bool
    lag: FloatArray  # (E, M) range time - round time


@numba.njit(cache=True)
def _round_ids(tag: np.ndarray, anchor: np.ndarray, time: FloatArray, merge_s: float) -> np.ndarray:
    """Round index of each row (sorted by tag, time): a new round at a new tag, at an
    anchor already in the round, or more than merge_s after the round's first range."""
    out = np.empty(tag.shape[0], dtype=np.int64)
    seen = np.full(int(anchor.max()) + 1, -1, dtype=np.int64)
    current = -1
    start = 0.0
    for i in range(tag.shape[0]):
        if (
            current < 0
            or tag[i] != tag[i - 1]
            or seen[anchor[i]] == current
            or time[i] - start > merge_s
        ):
            current += 1
            start = time[i]
        seen[anchor[i]] = current
        out[i] = current
    return out


def _rounds_by_platform(
    session: Session, ranges: pd.DataFrame, params: LsqParams
) -> dict[str, _Rounds]:
    anchors = anchor_positions(session)
    rows = clean_ranges(session, ranges, range_sigma_default(session, params.range_sigma_m))
    a_from = rows["from"].isin(list(anchors)).to_numpy()
    a_to = rows["to"].isin(list(anchors)).to_numpy()
    keep = a_from ^ a_to
    rows, a_from = rows[keep], a_from[keep]
    if rows.empty:
        return {}
    table = pd.DataFrame(
        {
            "tag": np.where(a_from, rows["to"].to_numpy(), rows["from"].to_numpy()),
            "anchor": np.where(a_from, rows["from"].to_numpy(), rows["to"].to_numpy()),
            "time": rows["time"].to_numpy(),
            "range": rows["range"].to_numpy(),
            "var": rows["var"].to_numpy(),
        }
    ).sort_values(["tag", "time"], kind="stable")
    tag_code = pd.factorize(table["tag"])[0]
    anchor_code = pd.factorize(table["anchor"])[0]
    rid = _round_ids(tag_code, anchor_code, table["time"].to_numpy(), params.round_max_s)
    table["round"] = rid
    table["slot"] = table.groupby("round", sort=False).cumcount().to_numpy()
    out: dict[str, _Rounds] = {}
    for tid, mine in table.groupby("tag", sort=True):
        r = mine["round"].to_numpy() - int(mine["round"].min())
        slot = mine["slot"].to_numpy()
        n_ep, width = int(r.max()) + 1, int(slot.max()) + 1
        t_round = mine["time"].to_numpy()[np.r_[r[1:] != r[:-1], True]]  # rows in time order
        pos = np.zeros((n_ep, width, 3))
        rng, var, lag = np.zeros((n_ep, width)), np.ones((n_ep, width)), np.zeros((n_ep, width))
        has = np.zeros((n_ep, width), dtype=bool)
        pos[r, slot] = np.stack([anchors[a] for a in mine["anchor"]])
        rng[r, slot] = mine["range"].to_numpy()
        var[r, slot] = mine["var"].to_numpy()
        lag[r, slot] = mine["time"].to_numpy() - t_round[r]
        has[r, slot] = True
        out[str(tid)] = _Rounds(t_round, pos, rng, var, has, lag)
    return out


def _linear_start(pos: FloatArray, rng: FloatArray, has: np.ndarray, up: FloatArray, dim: int):  # type: ignore[no-untyped-def]
    """Closed-form start: |X - a_i|^2 - |X - a_0|^2 is linear in X (a_0 the first anchor
    of the epoch); the 2-D model moves the known height's part to the ranges."""
    r2 = rng**2
    if dim == 2:
        r2 = r2 - (up[:, None] - pos[:, :, 2]) ** 2
    p = pos[:, :, :dim]
    m = 2.0 * (p - p[:, :1]) * has[..., None]
    b = ((p**2).sum(axis=2) - (p[:, :1] ** 2).sum(axis=2) - r2 + r2[:, :1]) * has
    n_mat = np.einsum("emi,emj->eij", m, m) + np.eye(dim)[None] * 1e-9
    x = np.linalg.solve(n_mat, np.einsum("emi,em->ei", m, b)[..., None])[..., 0]
    centroid = (p * has[..., None]).sum(axis=1) / np.maximum(has.sum(axis=1), 1)[:, None]
    return np.where(np.isfinite(x), x, centroid)


def _test(
    x: FloatArray, w: FloatArray, rd: _Rounds, up: FloatArray, dim: int, params: LsqParams
) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray, np.ndarray]:
    """HDOP, VDOP, chi-square, degrees of freedom and whether the test passes."""
    rho, a = _design(x, rd.pos, up, dim)
    a = a * rd.has[..., None]
    q = np.linalg.pinv(np.einsum("emi,emj->eij", a, a))
    hdop = np.sqrt(np.maximum(q[:, 0, 0] + q[:, 1, 1], 0.0))
    vdop = np.sqrt(np.maximum(q[:, 2, 2], 0.0)) if dim == 3 else np.full(x.shape[0], np.nan)
    stat = np.where(rd.has, w * (rd.rng - rho) ** 2 / rd.var, 0.0).sum(axis=1)
    dof = rd.has.sum(axis=1) - dim
    crit = chi2_ppf(1.0 - params.residual_alpha, np.maximum(dof, 1))
    passes = (dof < 1) | (stat <= crit)
    return hdop, vdop, stat, dof, passes


def _solve(rd: _Rounds, up: FloatArray, dim: int, params: LsqParams, x0: FloatArray | None):  # type: ignore[no-untyped-def]
    p = dataclasses.replace(params, dims=dim)
    start = _linear_start(rd.pos, rd.rng, rd.has, up, dim) if x0 is None else x0
    return _gauss_newton(rd.pos, rd.rng, rd.var, rd.has, up, p, x0=start)


def _mirror(x: FloatArray, rd: _Rounds, dim: int) -> FloatArray:
    """x reflected across the plane (line) best fitting each epoch's anchors."""
    p = rd.pos[:, :, :dim]
    count = np.maximum(rd.has.sum(axis=1), 1)[:, None]
    c = (p * rd.has[..., None]).sum(axis=1) / count
    d = (p - c[:, None]) * rd.has[..., None]
    normal = np.linalg.eigh(np.einsum("emi,emj->eij", d, d))[1][:, :, 0]
    return x - 2.0 * np.einsum("ei,ei->e", x - c, normal)[:, None] * normal


def _reference(t: FloatArray, x: FloatArray, good: np.ndarray, window_s: float) -> FloatArray:
    """The unambiguous fixes interpolated at t (NaN farther than window_s from any)."""
    out = np.full((t.shape[0], x.shape[1]), np.nan)
    if not good.any():
        return out
    tg = t[good]
    for i in range(x.shape[1]):
        out[:, i] = np.interp(t, tg, x[good, i])
    near = np.abs(tg[np.clip(np.searchsorted(tg, t), 0, tg.shape[0] - 1)] - t)
    near = np.minimum(near, np.abs(tg[np.clip(np.searchsorted(tg, t) - 1, 0, None)] - t))
    out[near > window_s] = np.nan
    return out


def _velocity(
    t: FloatArray, x: FloatArray, cov: FloatArray, ok: np.ndarray, params: LsqParams
) -> FloatArray:
    """The velocity at every epoch from the constant-velocity RTS over the accepted fixes
    (:func:`coopproc.stages.anchors.uwb_kf.cv_smooth`), NaN farther than
    ``rate_max_gap_s`` from one (a raw fix difference at 10 Hz and HDOP 29 is 5 m/s off)."""
    v = np.full(x.shape, np.nan)
    idx = np.flatnonzero(ok)
    if idx.shape[0] < 2:
        return v
    nan = np.full(x[idx].shape, np.nan)
    fix = LsqFixes(t[idx], x[idx], cov[idx], nan, nan[..., None] * nan[:, None], t[idx])
    smooth = cv_smooth(fix, dataclasses.replace(params, kf_velocity=False))[0]
    d = x.shape[1]
    for i in range(d):
        v[:, i] = np.interp(t, t[idx], smooth[:, d + i])
    near = _reference(t, x, ok, params.rate_max_gap_s)
    v[~np.isfinite(near).all(axis=1)] = np.nan
    return v


def _height(
    pid: str, session: Session, rd: _Rounds, params: LsqParams, anchors: FloatArray
) -> tuple[FloatArray, str]:
    """The planar platform's height at each epoch and a sentence saying where from."""
    declared = session.platforms[pid].antenna[0]
    if declared is not None:
        return np.full(rd.time.shape[0], float(declared)), "declared (session.toml height)"
    nav = session.nav.get(pid)
    if nav is not None and len(nav) > 0:
        return np.interp(rd.time, nav.time_s, nav.enu_m[:, 2]), "from its navigation"
    if params.tag_up_m is not None:
        return np.full(rd.time.shape[0], params.tag_up_m), "given ([fusion.lsq] tag_up_m)"
    span_up = float(np.ptp(anchors[:, 2]))
    span_h = float(np.max(np.ptp(anchors[:, :2], axis=0)))
    plane = float(np.mean(anchors[:, 2]))
    grid = plane - np.arange(0.0, 3.01, 0.25)
    four = rd.has.sum(axis=1) >= 4
    if span_up >= 0.5 and span_up >= 0.2 * span_h and four.sum() >= MIN_HEIGHT_FIXES:
        sub = _Rounds(*(getattr(rd, f.name)[four] for f in dataclasses.fields(rd)))
        x, _, w = _solve(sub, np.zeros(int(four.sum())), 3, params, None)
        _, vdop, _, _, passes = _test(x, w, sub, np.zeros(x.shape[0]), 3, params)
        good = passes & np.isfinite(x).all(axis=1) & (vdop <= params.hdop_max)
        if good.sum() >= MIN_HEIGHT_FIXES:
            near = good & (vdop <= np.percentile(vdop[good], NEAR_PERCENT))
            h = float(np.median(x[near, 2]))
            return np.full(rd.time.shape[0], h), f"estimated from {near.sum()} 3-D fixes"
    step = max(1, rd.time.shape[0] // 300)  # the search on 300 epochs at most
    sub = _Rounds(*(getattr(rd, f.name)[::step] for f in dataclasses.fields(rd)))
    best = _least_residual(sub, grid, params)
    best = _least_residual(sub, best + np.arange(-0.25, 0.251, 0.05), params)
    how = f"estimated by the least range residual, {best - plane:+.2f} m from the anchors' plane"
    return np.full(rd.time.shape[0], best), how


def _least_residual(sub: _Rounds, heights: FloatArray, params: LsqParams) -> float:
    """The height whose 2-D fixes have the least median chi-square per degree of freedom
    (6 Gauss-Newton steps from the closed-form start: a score, not the fixes)."""
    params = dataclasses.replace(params, iterations=min(params.iterations, 6))
    best, score = float(heights[0]), np.inf
    for h in heights:
        up = np.full(sub.time.shape[0], h)
        x, _, w = _solve(sub, up, 2, params, None)
        _, _, stat, dof, _ = _test(x, w, sub, up, 2, params)
        tested = (dof > 0) & np.isfinite(stat)
        s = float(np.median(stat[tested] / dof[tested])) if tested.any() else np.inf
        if s < score - 1e-9:
            best, score = float(h), s
    return best


def _platform(pid: str, session: Session, rd: _Rounds, params: LsqParams, anchors: FloatArray):  # type: ignore[no-untyped-def]
    planar = session.platforms[pid].antenna[1]
    dim = 2 if (params.dims == 2 if planar is None else planar) else 3
    up, how = _height(pid, session, rd, params, anchors) if dim == 2 else (rd.time * 0.0, "")
    enough = rd.has.sum(axis=1) >= (params.min_anchors or dim + 1)
    x, cov, w = _solve(rd, up, dim, params, None)
    # mirror guard
    xm, covm, wm = _solve(rd, up, dim, params, _mirror(x, rd, dim))
    pass1 = _test(x, w, rd, up, dim, params)[4] & np.isfinite(x).all(axis=1)
    pass2 = _test(xm, wm, rd, up, dim, params)[4] & np.isfinite(xm).all(axis=1)
    apart = np.linalg.norm(np.nan_to_num(xm - x), axis=1) > MIRROR_SEPARATION_M
    ambiguous = pass1 & pass2 & apart & enough
    swap = ~pass1 & pass2
    ref = _reference(rd.time, x, pass1 & ~ambiguous & enough, params.mirror_window_s)
    nearer = np.linalg.norm(xm - ref, axis=1) < np.linalg.norm(x - ref, axis=1)
    swap |= ambiguous & nearer
    x = np.where(swap[:, None], xm, x)
    unresolved = ambiguous & ~np.isfinite(ref).all(axis=1)
    # staggered ranges carried to the round's time with the velocity, solved again
    first = (pass1 | swap) & ~unresolved & enough
    v = _velocity(rd.time, x, np.where(swap[..., None, None], covm, cov), first, params)
    moving = np.isfinite(v).all(axis=1) & (rd.lag != 0).any(axis=1)
    if moving.any():
        shifted = rd.pos.copy()
        shifted[:, :, :dim] -= np.nan_to_num(v)[:, None, :] * rd.lag[..., None]
        rd = dataclasses.replace(rd, pos=shifted)
    x, cov, w = _solve(rd, up, dim, params, x)
    hdop, vdop, stat, dof, passes = _test(x, w, rd, up, dim, params)
    reach = np.where(rd.has, rd.rng, 0.0).max(axis=1) + DIVERGED_MARGIN_M
    far = np.linalg.norm(x - anchors[:, :dim].mean(axis=0), axis=1) > reach + np.ptp(anchors)
    status = np.select(
        [
            ~np.isfinite(x).all(axis=1) | far,
            unresolved,
            hdop > np.where(dof > 1, params.hdop_max, params.hdop_max_minimal),
            ~passes,
        ],
        ["diverged", "mirror", "dop", "residual"],
        "ok",
    )
    status = np.where(enough, status, "anchors")
    quality = pd.DataFrame(
        {"time": rd.time, "platform": pid, "method": "", "anchors": rd.has.sum(axis=1),
         "hdop": hdop, "vdop": vdop, "chi2": stat, "dof": dof,
         "up": up if dim == 2 else x[:, 2], "status": status}
    )  # fmt: skip
    ok = status == "ok"
    nan = np.full(x[ok].shape, np.nan)  # no velocity observations (range rates: lsq.py)
    fix = LsqFixes(
        time_s=rd.time[ok],
        pos=x[ok],
        cov=cov[ok],
        vel=nan,
        vel_cov=nan[..., None] * nan[:, None],
        up=(up if dim == 2 else x[:, 2])[ok],
    )
    note = _note(pid, dim, up, how, status)
    return fix, quality[quality["status"] != "anchors"], note, (dim, rd.time, up)


def _note(pid: str, dim: int, up: FloatArray, how: str, status: np.ndarray) -> str:
    counts = {s: int((status == s).sum()) for s in ("dop", "residual", "mirror", "diverged")}
    dropped = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    kind = f"2-D at height {np.median(up):.2f} m {how}" if dim == 2 else "3-D"
    head = f"{pid}: {int((status == 'ok').sum())} of {int((status != 'anchors').sum())} fixes"
    return f"{head} ({kind}); dropped: {dropped or 'none'} (lsq_quality.csv)"


def anchor_fixes(session: Session, ranges: pd.DataFrame, params: LsqParams) -> AnchorSolution:
    """The accepted fixes of every platform ranging to anchors (module docstring).

    ``lsq``, ``lsq_kf``, ``lsq_rts`` and ``range_*`` of one range set solve the same fixes:
    the last call's solution is given again for the same session, ranges (the same
    objects, held weakly: a spent session's samples are not kept) and parameters
    (hanyang_los: 2.2 s a solve)."""
    last = _LAST.get()
    if last is not None and last[0]() is session and last[1]() is ranges and last[2] == params:
        return last[3]
    solution = _anchor_fixes(session, ranges, params)
    _LAST.set((weakref.ref(session), weakref.ref(ranges), params, solution))
    return solution


_LAST: contextvars.ContextVar[
    tuple[weakref.ref[Session], weakref.ref[pd.DataFrame], LsqParams, AnchorSolution] | None
] = contextvars.ContextVar("coopproc_anchor_fixes_last", default=None)


def _anchor_fixes(session: Session, ranges: pd.DataFrame, params: LsqParams) -> AnchorSolution:
    anchors = np.stack(list(anchor_positions(session).values()))
    fixes: dict[str, LsqFixes] = {}
    quality, notes, geometry = [], [], {}
    for pid, rd in _rounds_by_platform(session, ranges, params).items():
        fix, q, note, geometry[pid] = _platform(pid, session, rd, params, anchors)
        if fix.time_s.shape[0]:
            fixes[pid] = fix
        quality.append(q)
        notes.append(note)
    frame = (
        pd.concat(quality, ignore_index=True)
        if quality
        else pd.DataFrame(columns=list(LSQ_QUALITY_COLUMNS))
    )
    return AnchorSolution(fixes, frame[list(LSQ_QUALITY_COLUMNS)], tuple(notes), geometry)


def lsq_quality_of(products: Mapping[str, PositionProduct]) -> pd.DataFrame | None:
    """lsq_quality.csv: the ``lsq*`` products' quality rows, once per range set (``lsq``
    and ``lsq_rts`` solve the same fixes), by method, platform and time; None without."""
    frames = [p.lsq_quality for p in products.values() if p.lsq_quality is not None]
    if not frames:
        return None
    table = pd.concat(frames, ignore_index=True)
    table = table.drop_duplicates(["method", "platform", "time"], keep="first")
    return table.sort_values(["method", "platform", "time"], kind="stable").reset_index(drop=True)
