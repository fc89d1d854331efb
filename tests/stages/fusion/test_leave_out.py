"""The cooperative solution without a pair's own ranges (stages/fusion/leave_out.py, issue 30)."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Trajectory
from coopproc.names import pair_members, pair_name
from coopproc.sim import Simulation, simulate
from coopproc.stages.fusion.fuse import FusionParams
from coopproc.stages.fusion.leave_out import MIN_LINKS, held_positions, leave_pair_out, pair_folds


def test_folds_spread_each_platforms_pairs() -> None:
    """Ten platforms, 45 pairs, 4 folds: each platform (9 pairs) loses at most 3 of them
    to one fold, the folds hold 11-12 pairs, and the split does not depend on the order."""
    ids = [f"P{i:02d}" for i in range(10)]
    pairs = [pair_name(a, b) for a, b in itertools.combinations(ids, 2)]
    fold = pair_folds(pairs, 4)
    assert fold == pair_folds(list(reversed(pairs)), 4)
    sizes = np.bincount(list(fold.values()))
    assert sizes.tolist() in (
        [12, 11, 11, 11],
        [11, 12, 11, 11],
        [11, 11, 12, 11],
        [11, 11, 11, 12],
    )
    for pid in ids:
        per_fold = np.bincount([fold[p] for p in pairs if pid in pair_members(p)], minlength=4)
        assert per_fold.max() <= 3 and per_fold.sum() == 9
    assert set(pair_folds(pairs[:3], 4).values()) == {0, 1, 2}  # never more folds than pairs


def test_held_positions_add_the_last_correction_to_the_navigation() -> None:
    nav = Trajectory("A", np.array([0.0, 10.0]), np.array([[0.0, 0, 0], [10.0, 0, 0]]))
    updates = Trajectory("A", np.array([2.0, 5.0]), np.array([[2.5, 1, 0], [5.0, -1, 0]]))
    out = held_positions(updates, nav, np.array([1.0, 2.0, 4.0, 5.0, 9.0]))
    expected = [[1.5, 1, 0], [2.5, 1, 0], [4.5, 1, 0], [5.0, -1, 0], [9.0, -1, 0]]
    np.testing.assert_allclose(out, expected)


@pytest.fixture(scope="module")
def network() -> Simulation:
    """Five platforms ranging in turn (the large scenario's network), four minutes."""
    return simulate("large", seed=3, duration_s=240.0, platforms=5)


def _left_out(sim: Simulation, frame: pd.DataFrame) -> dict[str, dict[str, np.ndarray]]:
    session = sim.session
    sigma = dict.fromkeys(session.ranges.pairs, 0.1)
    out = leave_pair_out(session, frame, FusionParams(cp_folds=4), sigma, {}, {})
    return {p: {m: t.enu_m for m, t in ends.items()} for p, ends in out.trajectories.items()}


def test_a_pairs_solution_does_not_see_its_own_ranges(network: Simulation) -> None:
    """Corrupt one pair's ranges by 2 m: its own left-out solution stays bit for bit what
    it was, the pairs of the other folds (whose fusions hold the corrupted ranges) move."""
    session = network.session
    frame = session.ranges.frame
    before = _left_out(network, frame)
    assert set(before) == set(session.ranges.pairs)  # every end has >= 2 other pairs
    target = session.ranges.pairs[0]
    rows = (frame["from"].astype(str) + "-" + frame["to"].astype(str)).isin(
        [target, "-".join(reversed(pair_members(target)))]
    )
    assert rows.any()
    bad = frame.assign(range=frame["range"].where(~rows, frame["range"] + 2.0))
    after = _left_out(network, bad)
    for m in before[target]:
        np.testing.assert_array_equal(after[target][m], before[target][m])
    fold = pair_folds(list(session.ranges.pairs), 4)
    others = [p for p in session.ranges.pairs if fold[p] != fold[target]]
    moved = [
        p for p in others if any(np.abs(after[p][m] - before[p][m]).max() > 0.05 for m in before[p])
    ]
    assert moved, "the corrupted ranges reach no other fold's fusion"


def test_the_left_out_solution_is_close_to_the_truth(network: Simulation) -> None:
    """The fold fusions are real positioning: each end within a few decimetres of the
    truth on average (the navigation alone is worse)."""
    session = network.session
    sol = leave_pair_out(
        session, session.ranges.frame, FusionParams(cp_folds=4),
        dict.fromkeys(session.ranges.pairs, 0.1), {}, {},
    )  # fmt: skip
    for pair, ends in sol.trajectories.items():
        for m, traj in ends.items():
            truth = network.truth.trajectories[m].interpolate(traj.time_s)
            err = np.linalg.norm(traj.enu_m[:, :2] - truth[:, :2], axis=1)
            nav = session.nav[m].interpolate(traj.time_s)
            nav_err = np.linalg.norm(nav[:, :2] - truth[:, :2], axis=1)
            if session.platforms[m].role == "follower":
                assert np.nanmean(err) < max(0.3, np.nanmean(nav_err)), (pair, m)


def test_three_platforms_keep_paper_000s_solution() -> None:
    """Each platform of a triangle has one other pair in a fold: fewer than MIN_LINKS, so
    every pair keeps the solution of all ranges, and says why."""
    sim = simulate("paper-experiment", seed=0, duration_s=60.0)
    session = sim.session
    sol = leave_pair_out(
        session, session.ranges.frame, FusionParams(cp_folds=4),
        dict.fromkeys(session.ranges.pairs, 0.1), {}, {},
    )  # fmt: skip
    assert MIN_LINKS == 2 and not sol.trajectories and sol.folds == 3
    assert set(sol.kept) == set(session.ranges.pairs)
    assert all("1 other pair in its fold" in why for why in sol.kept.values()), sol.kept
    off = leave_pair_out(session, session.ranges.frame, FusionParams(cp_folds=0), {}, {}, {})
    assert off.folds == 0 and not off.trajectories
