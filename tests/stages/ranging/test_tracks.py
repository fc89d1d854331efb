"""The ranging stage's per-platform navigation columns (issue 11): the same inputs as a
pair prepared alone, and released after each platform's last pair."""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np

from coopproc.model import RangeTable
from coopproc.sim import simulate
from coopproc.stages.ranging.config import RangingConfig
from coopproc.stages.ranging.pair import prepare_pair
from coopproc.stages.ranging.rn import platform_velocity
from coopproc.stages.ranging.table import pair_columns, pair_rows
from coopproc.stages.ranging.tracks import PlatformTracks


def test_shared_tracks_give_each_pair_its_own_inputs() -> None:
    session = simulate("dr-faults", seed=0, duration_s=30.0).session
    config = RangingConfig()
    cp = dict(session.nav)  # any solution: the cooperative one is read per pair anyway
    pairs = list(session.ranges.pairs)
    tracks = PlatformTracks(session, config, pairs)
    for pair in pairs:
        shared = prepare_pair(session, cp, config, pair, tracks)
        alone = prepare_pair(session, cp, config, pair)
        for f in fields(shared):
            a, b = getattr(shared, f.name), getattr(alone, f.name)
            if isinstance(a, np.ndarray):
                assert np.array_equal(a, b, equal_nan=True), f.name
            elif isinstance(a, tuple) and isinstance(a[0], np.ndarray):
                assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))
            else:
                assert a == b, f.name
        tracks.done(pair)
    assert not tracks._positions and not tracks._velocities  # all released


def test_velocity_is_platform_velocity() -> None:
    session = simulate("dr-faults", seed=0, duration_s=20.0).session
    pid = next(iter(session.moving_platforms()))
    nav = session.nav[pid]
    t = np.linspace(nav.time_s[0] - 1.0, nav.time_s[-1] + 1.0, 333)
    rng = np.random.default_rng(0)
    with_vel = replace(nav, vel_enu_mps=rng.normal(size=(len(nav), 3)))
    for traj in (nav, with_vel):
        sess = replace(session, nav={**session.nav, pid: traj})
        for velocity in ("difference", "nav"):
            config = replace(RangingConfig(), rn=replace(RangingConfig().rn, velocity=velocity))
            got = PlatformTracks(sess, config, [f"{pid}-x"]).velocity(pid, t)
            use = traj
            if velocity == "difference" or traj.vel_enu_mps is None:
                use = replace(traj, vel_enu_mps=None)
            assert np.array_equal(got, platform_velocity(use, t), equal_nan=True)
            inside = (t >= traj.time_s[0]) & (t <= traj.time_s[-1])
            assert np.isfinite(got[inside]).all() and np.isnan(got[~inside]).all()


def test_pair_columns_are_pair_rows() -> None:
    session = simulate("dr-faults", seed=0, duration_s=20.0).session
    frame = session.ranges.frame.sample(frac=1.0, random_state=0)  # rows out of time order
    time = frame["time"].to_numpy(dtype=np.float64).copy()
    time[: time.shape[0] - 1 : 9] = time[1::9]  # ties
    time[5] = np.nan
    ranges = RangeTable(frame.assign(time=time).reset_index(drop=True))
    shuffled = replace(session, ranges=ranges)
    for pair in shuffled.ranges.pairs:
        rows = pair_rows(shuffled, pair)
        t, observed = pair_columns(shuffled, pair)
        assert np.array_equal(t, rows["time"].to_numpy(dtype=np.float64), equal_nan=True)
        assert np.array_equal(observed, rows["range"].to_numpy(dtype=np.float64), equal_nan=True)
