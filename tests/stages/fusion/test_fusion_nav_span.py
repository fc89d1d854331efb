"""Issue 29, deliverable 4: each platform is fused over its own navigation span.

One platform's shorter navigation leaves out its own ranges outside it, never the other
platforms' epochs; a leader's fix only inside its span; a platform is recorded and
reported only there, and one whose navigation starts late starts from its first sample.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from coopproc.model import RangeTable, Session, Trajectory
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.fusion.inputs import fusion_inputs
from coopproc.stages.fusion.nav_span import covered_rows, epoch_bounds
from coopproc.stages.fusion.output import recorded_slots
from coopproc.stages.shared.data import clean_range_rows
from tests.stages.fusion.test_fusion import dr_error, horizontal_error, make_session


def _cut(session: Session, pid: str, lo: float, hi: float) -> Session:
    """``session`` with ``pid``'s navigation kept inside ``lo`` .. ``hi`` only."""
    traj = session.nav[pid]
    keep = (traj.time_s >= lo) & (traj.time_s <= hi)
    sigma = None if traj.sigma_enu_m is None else traj.sigma_enu_m[keep]
    short = Trajectory(pid, traj.time_s[keep], traj.enu_m[keep], sigma_enu_m=sigma)
    return dataclasses.replace(session, nav={**session.nav, pid: short})


def _without(session: Session, pid: str) -> Session:
    """``session`` without platform ``pid`` and its ranges."""
    frame = session.ranges.frame
    frame = frame[(frame["from"] != pid) & (frame["to"] != pid)].reset_index(drop=True)
    platforms = {p: v for p, v in session.platforms.items() if p != pid}
    nav = {p: v for p, v in session.nav.items() if p != pid}
    return dataclasses.replace(session, platforms=platforms, nav=nav, ranges=RangeTable(frame))


@pytest.fixture(scope="module")
def base() -> tuple[Session, dict[str, np.ndarray], np.ndarray]:
    return make_session()


def test_a_shorter_navigation_cuts_only_its_own_platform(base) -> None:
    session, truth, epochs = base
    short = _cut(session, "C", 0.0, 200.05)
    out = fuse(short, short.ranges.frame, FusionParams())
    # the A-B ranges go on to the end: every range time is still an epoch
    assert out.epochs_s == pytest.approx(epochs)
    for kind in ("forward", "smoothed"):
        tracks = getattr(out, kind)
        for pid in "AB":
            assert tracks[pid].time_s == pytest.approx(epochs)
        assert tracks["C"].time_s == pytest.approx(epochs[epochs <= 200.05])
    # C's ranges after its navigation ends are left out of the update, the others' kept
    obs = out.observations
    with_c = (obs["from"] == "C") | (obs["to"] == "C")
    assert obs.loc[with_c, "time"].max() == 200.0
    assert obs.loc[~with_c, "time"].max() == epochs[-1]
    # A is still fused after C ends: better than its own navigation there
    after = epochs > 200.05
    fused = horizontal_error(out.smoothed["A"], truth["A"])[after]
    assert fused.mean() < 0.6 * dr_error(short, "A", truth["A"][after], epochs[after]).mean()


def test_a_late_navigation_starts_at_its_first_sample(base) -> None:
    session, truth, epochs = base
    late = _cut(session, "C", 100.05, 400.0)
    params = FusionParams(init_from_anchors=False)
    inputs = fusion_inputs(late, late.ranges.frame, params)
    moving = inputs.moving
    c = moving.index("C")
    # C's initial state: its navigation at its first sample, with the initial sigma
    assert inputs.x0[2 * c : 2 * c + 2] == pytest.approx(late.nav["C"].enu_m[0, :2])
    assert np.diag(inputs.c0)[2 * c : 2 * c + 2] == pytest.approx([1.0, 1.0])
    assert np.count_nonzero(inputs.c0 - np.diag(np.diag(inputs.c0))) == 0
    out = fuse(late, late.ranges.frame, params)
    assert out.smoothed["C"].time_s == pytest.approx(epochs[epochs >= 100.05])
    assert out.smoothed["A"].time_s == pytest.approx(epochs)
    # before C enters nothing involves it: A and B's forward solution is that of a fusion
    # without C at all
    alone = fuse(_without(late, "C"), _without(late, "C").ranges.frame, params)
    before = epochs < 100.05
    for pid in "AB":
        got = out.forward[pid].enu_m[before]
        assert got == pytest.approx(alone.forward[pid].enu_m[before], abs=1e-9)
    # once it enters C is fused like the others: well below its own navigation's error
    inside = epochs >= 100.05
    fused = horizontal_error(out.smoothed["C"], truth["C"][inside])
    assert fused.mean() < 0.6 * dr_error(late, "C", truth["C"][inside], epochs[inside]).mean()


def test_merged_epochs_before_a_late_platform_enters(base) -> None:
    session, _, _ = base
    late = _cut(session, "C", 100.05, 400.0)  # its first sample at 100.1 s
    frame = late.ranges.frame.copy()
    frame.loc[frame["pair"] == "A-C", "time"] += 0.15  # A-C 150 ms after the others
    out = fuse(late, frame, FusionParams(epoch_merge_s=0.2))
    # the A-C range at 100.15 s is in the epoch at 100.0 s, before C's first sample: the
    # state carries that sample, the range model C's motion from it (no NaN anywhere)
    obs = out.observations
    assert ((obs["time"] == 100.0) & (obs["to"] == "C")).sum() == 1
    assert np.isfinite(obs["innovation"]).all()
    for pid in "ABC":
        assert np.isfinite(out.smoothed[pid].enu_m).all()
    assert out.smoothed["C"].time_s[0] == 101.0


def test_nav_rate_output_inside_each_span(base) -> None:
    session, _, _ = base
    short = _cut(session, "C", 50.0, 200.05)
    out = fuse(short, short.ranges.frame, FusionParams(), output="nav")
    nav_t = session.nav["A"].time_s
    assert out.smoothed["A"].time_s == pytest.approx(nav_t[(nav_t >= 1.0) & (nav_t <= 299.0)])
    c_t = short.nav["C"].time_s
    want = c_t[(c_t >= 50.0) & (c_t <= 200.0)]  # its first and last epoch inside its span
    for kind in ("forward", "smoothed"):
        track = getattr(out, kind)["C"]
        assert track.time_s == pytest.approx(want)
        assert np.isfinite(track.enu_m).all()


def test_recorded_slots_inside_each_span(base) -> None:
    session, _, epochs = base
    short = _cut(session, "C", 50.0, 200.05)
    moving = list(short.moving_platforms())
    frame = short.ranges.frame
    k_lo, k_hi = epoch_bounds(short, moving, epochs)
    c = moving.index("C")
    assert epochs[k_lo[c]] == 50.0 and epochs[k_hi[c] - 1] == 200.0
    for record_all in (False, True):
        ptr, plat = recorded_slots(short, frame, moving, epochs, record_all)
        k = np.repeat(np.arange(epochs.shape[0]), np.diff(ptr))
        mine = k[plat == c]
        assert mine.min() == k_lo[c] and mine.max() == k_hi[c] - 1
        for p in range(len(moving)):
            if p != c:
                assert k[plat == p].min() == 0 and k[plat == p].max() == epochs.shape[0] - 1


def test_covered_rows_per_end() -> None:
    session, _, _ = make_session(duration_s=30.0)
    short = _cut(session, "C", 10.0, 20.0)
    rows = clean_range_rows(short, short.ranges.frame, 0.1)
    keep = covered_rows(short, rows, list(short.moving_platforms()))
    ids = np.array(rows.ids)
    with_c = (ids[rows.from_code] == "C") | (ids[rows.to_code] == "C")
    inside = (rows.time >= 10.0) & (rows.time <= 20.0)
    assert np.array_equal(keep, ~with_c | inside)
