"""The cooperative solution without a pair's own ranges: leave-pair-out folds (issue 30).

Paper 000's DI-Based method fuses each pair's dead-reckoning DI with the DI of the
cooperative solution (CP DI, eq. (1)) and judges the pair's ranges against the result.
When that cooperative solution was fused from the same ranges, its DI follows them: an NLOS
error of the pair pulls the CP DI along (which is why the DI stage masks the CP DI in a
second pass), and the smoothed DI leans towards the very ranges it is to judge.

Here the CP DI of pair (i, j) comes from a fusion without (i, j)'s ranges. One fusion per
pair would cost as many forward filters as there are pairs (45 at ten platforms), so the
pairs are split into ``K = min(cp_folds, pairs)`` folds and each fold's pairs share one
fusion of all the other ranges (:func:`pair_folds`: a fold takes as few of one platform's
pairs as the count allows, so each platform keeps most of its links in every fold). The
fold fusions are forward filters of paper 000's position state with the observed fusion's
calibration (per-pair sigmas, drift scales, platform range biases), so they cost one
forward pass each: no smoother, no self-calibration rounds.

A fold's filter has no epochs at the left-out pair's range times; its solution there is
what the forward filter holds between its updates: the platform's navigation plus the
correction of its last update (the position state's prediction adds the DR increment, so
the correction is constant between updates: :func:`held_positions`).

A pair keeps the cooperative solution of all ranges (paper 000's) when one of its moving
ends has fewer than :data:`MIN_LINKS` other pairs in its fold and is no leader (a leader's
own GNSS/INS navigation is its solution without ranges) and no anchor: without the pair's
ranges its position is not determined, and a CP DI from it would be worse than paper
000's (three platforms, each ranging the other two: paper 000's experiment and
``sample_logs``; a single pair: its Table 1). Sessions of four or more platforms, or
with anchors, get the leave-pair-out solution.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, Session, Trajectory
from coopproc.names import pair_members
from coopproc.stages.base import LeftOutCP
from coopproc.stages.fusion.calibration_bias import code_groups, corrected, pair_codes
from coopproc.stages.fusion.fuse import fuse
from coopproc.stages.fusion.params import FusionParams

__all__ = ["MIN_LINKS", "held_positions", "leave_pair_out", "pair_folds"]

#: A moving end of a left-out pair needs this many other pairs in the fusion without it:
#: with one, its position across the range is not determined (one range to a point), and
#: after a gap in its navigation its solution stays off: the nav-gaps scenario, A-B left
#: out with A ranging only C, DI-Based RMSE 0.127 m against 0.031 m with all ranges, one
#: of its two NLOS events missed. Two ranges to distinct points fix a 2-D position.
MIN_LINKS = 2


def pair_folds(pairs: list[str], k: int) -> dict[str, int]:
    """Each pair's fold, ``k`` folds: greedy, the pairs in sorted order, each to the fold
    where its two platforms have the fewest pairs so far (then the fold with the fewest
    pairs, then the lowest index): deterministic, and a fold leaves each platform most of
    its links."""
    k = max(1, min(k, len(pairs)))
    load: list[dict[str, int]] = [{} for _ in range(k)]
    size = [0] * k
    out: dict[str, int] = {}
    for pair in sorted(pairs):
        a, b = pair_members(pair)
        f = min(
            range(k),
            key=lambda i: (max(load[i].get(a, 0), load[i].get(b, 0)), size[i], i),
        )
        out[pair] = f
        load[f][a] = load[f].get(a, 0) + 1
        load[f][b] = load[f].get(b, 0) + 1
        size[f] += 1
    return out


def held_positions(solution: Trajectory, nav: Trajectory, time_s: FloatArray) -> FloatArray:
    """A forward position-state filter's positions at ``time_s`` from its updates
    (``solution``, at its epochs) and the platform's navigation: the navigation plus the
    correction (solution - navigation) of the last update at or before each time (the
    first update's before it)."""
    corr = solution.enu_m - nav.interpolate(solution.time_s)
    at = np.searchsorted(solution.time_s, time_s, side="right") - 1
    return nav.interpolate(time_s) + corr[np.clip(at, 0, None)]


def leave_pair_out(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    pair_sigma_m: Mapping[str, float],
    drift_scale: Mapping[str, float],
    platform_bias_m: Mapping[str, float],
) -> LeftOutCP:
    """Each pair's cooperative solution from the ranges of the other folds (module
    docstring). ``ranges``: columns time, from, to, range[, sigma], the observed set the
    full solution was fused from; the figures are that fusion's calibration."""
    if params.cp_folds == 0 or len(ranges) == 0:
        return LeftOutCP({}, {}, 0, {})
    codes = pair_codes(ranges["from"], ranges["to"])
    groups = dict(code_groups(codes.code, len(codes.names)))
    names = [codes.names[c] for c in sorted(groups)]
    fold = pair_folds(names, params.cp_folds)
    folds = max(fold.values(), default=-1) + 1
    sigma = np.empty(len(ranges))
    for code, rows in groups.items():
        sigma[rows] = pair_sigma_m.get(codes.names[code], np.nan)
    given = ranges.assign(sigma=np.where(np.isfinite(sigma), sigma, ranges.get("sigma", np.nan)))
    if platform_bias_m:
        given = corrected(given, platform_bias_m)
    plain = dataclasses.replace(
        params, state="position", cp_state="position", smoother=False, self_calibrate=False
    )
    trajectories: dict[str, dict[str, Trajectory]] = {}
    kept: dict[str, str] = {}
    time = ranges["time"].to_numpy(dtype=np.float64)
    for f in range(folds):
        mine = [p for p in names if fold[p] == f]
        others = [p for p in names if fold[p] != f]
        links: dict[str, int] = {}
        for p in others:
            for m in pair_members(p):
                links[m] = links.get(m, 0) + 1
        todo = []
        for pair in mine:
            weak = [
                m
                for m in pair_members(pair)
                if links.get(m, 0) < MIN_LINKS
                and session.platforms[m].role not in ("anchor", "leader")
            ]
            if weak:
                n = links.get(weak[0], 0)
                kept[pair] = f"{weak[0]} has {n} other pair{'' if n == 1 else 's'} in its fold"
            else:
                todo.append(pair)
        if not todo:
            continue
        drop = np.zeros(len(ranges), dtype=bool)
        for code, rows in groups.items():
            if fold[codes.names[code]] == f:
                drop[rows] = True
        fused = fuse(
            session, given.loc[~drop], plain, output="ranges", drift_scale=drift_scale,
            smoothed_sigma=False, forward=True, forward_sigma=False,
        )  # fmt: skip
        for pair in todo:
            t = np.unique(time[groups[codes.names.index(pair)]])
            ends: dict[str, Trajectory] = {}
            for m in pair_members(pair):
                if session.platforms[m].role == "anchor":
                    continue  # the ranging stage places an anchor itself
                solution = fused.forward.get(m)
                if solution is not None and len(solution):
                    ends[m] = Trajectory(m, t, held_positions(solution, session.nav[m], t))
                elif session.platforms[m].role == "leader" and m in session.nav:
                    ends[m] = Trajectory(m, t, session.nav[m].interpolate(t))
                else:
                    kept[pair] = f"the fusion without it has no solution for {m}"
                    break
            else:
                trajectories[pair] = ends
    return LeftOutCP(trajectories, fold, folds, kept)
