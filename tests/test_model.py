"""Known answers for the model's small helpers."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.model import Trajectory, pair_members, pair_name


def _line() -> Trajectory:
    # 1 s epochs along east, with a 10 s gap between t = 4 and t = 14
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 14.0, 15.0])
    enu = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    return Trajectory("A", t, enu)


def test_interpolate_is_linear_inside_and_nan_outside() -> None:
    pos = _line().interpolate(np.array([-1.0, 0.5, 9.0, 15.0, 16.0]))
    assert np.isnan(pos[0]).all() and np.isnan(pos[4]).all()
    assert pos[1, 0] == pytest.approx(0.5)
    assert pos[2, 0] == pytest.approx(9.0)
    assert pos[3, 0] == pytest.approx(15.0)


def test_interpolate_within_leaves_gaps_empty() -> None:
    traj = _line()
    pos = traj.interpolate_within(np.array([2.5, 4.0, 9.0, 14.0, 14.5]))
    assert pos[0, 0] == pytest.approx(2.5)
    assert pos[1, 0] == pytest.approx(4.0)  # on the epoch before the gap
    assert np.isnan(pos[2]).all()  # inside the 10 s gap (median step 1 s: limit 2.5 s)
    assert pos[3, 0] == pytest.approx(14.0)  # on the epoch after it
    assert pos[4, 0] == pytest.approx(14.5)
    # an explicit limit above the gap interpolates across it
    assert traj.interpolate_within(np.array([9.0]), max_gap_s=11.0)[0, 0] == pytest.approx(9.0)


@pytest.mark.parametrize(("a", "b", "name"), [("B", "A", "A-B"), ("uav3", "C", "C-uav3")])
def test_pair_names_are_sorted_and_split_back(a: str, b: str, name: str) -> None:
    assert pair_name(a, b) == name
    assert pair_members(name) == tuple(sorted((a, b)))


def test_a_session_without_samples_keeps_what_writing_reads() -> None:
    import gc
    import weakref

    from coopproc.sim import simulate

    session = simulate("paper-experiment", seed=0, duration_s=30.0).session
    nav = weakref.ref(next(iter(session.nav.values())))
    light = session.without_samples()
    assert (light.name, light.root, light.inputs, light.notes) == (
        session.name, session.root, session.inputs, session.notes,
    )  # fmt: skip
    assert light.platforms is session.platforms and light.config is session.config
    assert light.origin_llh == session.origin_llh
    assert not light.nav and not light.reference and len(light.ranges) == 0
    assert list(light.ranges.frame.columns) == list(session.ranges.frame.columns)
    assert len(session.ranges) > 50  # the original is untouched
    del session
    gc.collect()
    assert nav() is None  # nothing of the light session holds the samples
