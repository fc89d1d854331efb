"""Geometry-aware anchor fixes (coopproc.stages.anchors.anchor_lsq) and the range-by-range
EKF (range_kf.py) on small simulated tags: the mirror of three anchors whose horizontal
projections are collinear, staggered ranges, the height, no simultaneous ranges."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Platform, RangeTable, Session, SessionConfig, pair_name
from coopproc.stages.anchors.anchor_lsq import anchor_fixes
from coopproc.stages.anchors.range_kf import range_kf_positions
from coopproc.stages.shared.lsq import LsqParams, robust_lsq_positions

#: hanyang_los's cluster: a3, a5, a9 project onto the line x = 2.5775 (a5 above a9)
CLUSTER = {
    "a12": (0.69, 0.87, 0.5),
    "a3": (2.5775, 0.87, 1.97),
    "a5": (2.5775, -0.87, 1.97),
    "a9": (2.5775, -0.87, 0.5),
}
SQUARE = {"N1": (0.0, 0.0, 2.0), "N2": (20.0, 0.0, 2.5), "N3": (20.0, 20.0, 3.0)}
SQUARE |= {"N4": (0.0, 20.0, 2.2), "N5": (10.0, -5.0, 2.8), "N6": (-5.0, 10.0, 2.4)}


def _session(
    anchors: dict[str, tuple[float, float, float]],
    rows: list[tuple[float, str, float]],
    antenna: tuple[float | None, bool | None] = (None, None),
) -> Session:
    platforms = {"T": Platform("T", role="tag", antenna=antenna)}
    for aid, pos in anchors.items():
        platforms[aid] = Platform(aid, role="anchor", position_enu_m=pos)
    t, a, r = zip(*rows, strict=True)
    frame = pd.DataFrame(
        {"time": t, "pair": [pair_name("T", x) for x in a], "from": "T", "to": a, "range": r}
    )
    return Session(
        config=SessionConfig(platforms=platforms, uwb_sigma_m=0.05),
        platforms=platforms,
        nav={},
        reference={},
        ranges=RangeTable(frame),
        origin_llh=(0.0, 0.0, 0.0),
        root=Path("anchors"),
    )


def _ranges(anchors, truth, times, order, noise, seed=1):  # type: ignore[no-untyped-def]
    """One range per (time, anchor) of ``order``: (time, anchor, range) rows."""
    rng = np.random.default_rng(seed)
    rows = []
    for t, p, names in zip(times, truth, order, strict=True):
        for k, aid in enumerate(names):
            true = float(np.linalg.norm(p(k) - np.array(anchors[aid])))
            rows.append((t + k * 0.001, aid, true + float(rng.normal(0.0, noise))))
    return rows


@pytest.fixture(scope="module")
def walk_away() -> tuple[Session, np.ndarray, np.ndarray]:
    """A tag at 1.0 m walking from 10 m to 50 m from the cluster at 1 m/s, 10 Hz rounds,
    every 4th without a12 (the mirror across x = 2.5775 fits those exactly)."""
    times = np.arange(0.0, 40.0, 0.1)
    xy = np.stack([10.0 + 1.0 * times, -2.0 + np.sin(times / 6.0)], 1)
    order = [list(CLUSTER)[1:] if i % 4 == 3 else list(CLUSTER) for i in range(len(times))]
    truth = [lambda k, p=p: np.array([p[0], p[1], 1.0]) for p in xy]
    rows = _ranges(CLUSTER, truth, times, order, 0.01)
    return _session(CLUSTER, rows), times, xy


def test_three_anchor_mirror_is_resolved_by_the_unambiguous_fixes(walk_away) -> None:  # type: ignore[no-untyped-def]
    session, times, xy = walk_away
    frame = session.ranges.frame
    # the old solver starts at the centroid (x = 2.1, the mirror's side): it flips
    old = robust_lsq_positions(session, frame, LsqParams(tag_up_m=1.0, epoch_merge_s=0.005))
    t_old = old["T"].time_s
    old_true = np.stack([np.interp(t_old, times, xy[:, i]) for i in (0, 1)], 1)
    assert (
        np.linalg.norm(old["T"].enu_m[:, :2] - old_true, axis=1).max() > 20.0
    )  # measured 90 m: the 40-90 m flips of issue 31
    # every 3-anchor fix kept (by default those with HDOP > 15 are dropped)
    sol = anchor_fixes(session, frame, LsqParams(hdop_max_minimal=50.0))
    fix = sol.fixes["T"]
    true = np.stack([np.interp(fix.time_s, times + 0.003, xy[:, i]) for i in (0, 1)], 1)
    err = np.linalg.norm(fix.pos - true, axis=1)
    q = sol.quality
    three = (q.loc[q["status"] == "ok", "anchors"] == 3).to_numpy()
    assert three.sum() > 80  # the 3-anchor epochs have fixes, on the right side
    assert err[three].max() < 1.5 and err.max() < 1.5  # measured 0.65 m (HDOP 30 at 50 m)
    # the height from the nearest 3-D fixes (true 1.0 m; measured 1.36 m, all: 1.94 m)
    assert abs(sol.geometry["T"][2][0] - 1.0) < 0.5
    assert "estimated from 30 3-D fixes" in sol.notes[0]


def test_a_mirror_without_unambiguous_fixes_is_dropped(walk_away) -> None:  # type: ignore[no-untyped-def]
    session, _, _ = walk_away
    frame = session.ranges.frame
    three = frame[frame["to"] != "a12"]
    sol = anchor_fixes(session, three, LsqParams(tag_up_m=1.0))
    assert "T" not in sol.fixes  # no position is written: both sides fit
    assert (sol.quality["status"] == "mirror").mean() > 0.95
    assert "mirror" in sol.notes[0]


def test_staggered_ranges_are_carried_to_the_round_time() -> None:
    """Six anchors ranged one at a time 25 ms apart (a round of 150 ms) from a tag at
    1.5 m/s: a range 125 ms old is 0.19 m long or short; carried with the velocity, the
    fixes keep to the noise."""
    times = np.arange(0.0, 60.0, 0.15)
    speed = np.array([1.5, 0.5 * 1.5, 0.0]) / np.sqrt(1.25)

    def at(t: float) -> np.ndarray:
        return np.array([2.0, 3.0, 1.2]) + speed * t

    rng = np.random.default_rng(3)
    rows = []
    for t in times:
        for k, aid in enumerate(SQUARE):
            tk = t + 0.025 * k
            rows.append(
                (tk, aid, float(np.linalg.norm(at(tk) - SQUARE[aid]) + rng.normal(0, 0.01)))
            )
    session = _session(SQUARE, rows, antenna=(1.2, None))
    sol = anchor_fixes(session, session.ranges.frame, LsqParams())
    fix = sol.fixes["T"]
    assert (sol.quality["anchors"] == 6).all() and "declared" in sol.notes[0]
    err = np.linalg.norm(fix.pos - np.stack([at(t) for t in fix.time_s])[:, :2], axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.03  # measured 0.011 m; smeared: ~0.1 m
    assert np.allclose(fix.up, 1.2)


def test_range_kf_needs_no_simultaneous_ranges() -> None:
    """One range every 0.2 s, anchors in turn (1.2 s a round, as miluv1): range_rts
    follows a tag on a circle within the noise, in 3-D (no height declared)."""
    times = np.arange(0.0, 120.0, 0.2)
    names = list(SQUARE)

    def at(t: float) -> np.ndarray:
        w = 2 * np.pi / 60.0
        return np.array([8.0 + 4.0 * np.cos(w * t), 8.0 + 4.0 * np.sin(w * t), 1.0])

    rng = np.random.default_rng(5)
    rows = [
        (t, names[i % 6], float(np.linalg.norm(at(t) - SQUARE[names[i % 6]]) + rng.normal(0, 0.05)))
        for i, t in enumerate(times)
    ]
    session = _session(SQUARE, rows)
    frame = session.ranges.frame
    out = range_kf_positions(session, frame, LsqParams(), smooth=True)["T"]
    # a position at every range from the first fix (its 6-anchor round: 1 s)
    assert out.time_s.shape[0] >= times.shape[0] - 6
    truth = np.stack([at(t) for t in out.time_s])
    err = np.hypot(*(out.enu_m[:, :2] - truth[:, :2]).T)
    assert np.sqrt(np.mean(err[10:] ** 2)) < 0.1  # measured 0.04 m, sigma 0.05 m
    assert anchor_fixes(session, frame, LsqParams(round_max_s=0.25)).fixes == {}
