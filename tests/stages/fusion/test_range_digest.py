"""A processed range set holding the observed ranges gets the observed fusion (issue 11)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from coopproc.sim import simulate
from coopproc.stages.base import PositionInput
from coopproc.stages.fusion.entry import fusion_stage
from coopproc.stages.fusion.fuse import FusionParams
from coopproc.stages.fusion.range_digest import range_rows_digest


@pytest.fixture(scope="module")
def session():
    # dr-faults: drifts the declared sigmas do not cover, so the self-calibration inflates
    # them and notes it (the notes a reused product must name for its own range set)
    return simulate("dr-faults", seed=0, duration_s=60.0).session


def _observed(session) -> pd.DataFrame:
    return session.ranges.frame[["time", "from", "to", "range", "sigma"]].reset_index(drop=True)


def _pair_major(frame: pd.DataFrame) -> pd.DataFrame:
    """The rows listed pair by pair, as the run lists a processed range set."""
    pair = frame["from"].astype(str) + "-" + frame["to"].astype(str)
    order = np.lexsort((frame["time"].to_numpy(), pair.to_numpy()))
    return frame.iloc[order].reset_index(drop=True)


def test_digest_is_of_the_ranges_not_of_their_listing(session) -> None:
    frame = _observed(session)
    digest = range_rows_digest(session, frame, 0.15)
    shuffled = frame.sample(frac=1.0, random_state=3).reset_index(drop=True)
    swapped = shuffled.rename(columns={"from": "to", "to": "from"})
    assert range_rows_digest(session, swapped, 0.15) == digest
    # a missing sigma is the default sigma
    missing = range_rows_digest(session, frame.assign(sigma=np.nan), 0.25)
    assert missing == range_rows_digest(session, frame.assign(sigma=0.25), 0.15)
    assert missing != range_rows_digest(session, frame.assign(sigma=0.2), 0.15)
    for changed in (
        frame.assign(range=frame["range"].where(frame.index != 7, frame["range"] + 1e-9)),
        frame.assign(sigma=frame["sigma"].where(frame.index != 7, 0.3)),
        frame.assign(time=frame["time"].where(frame.index != 7, frame["time"] + 1e-6)),
        frame.drop(index=7),
        pd.concat([frame, frame.iloc[[7]].assign(range=np.nan)]),  # a NaN row more: not fused
    ):
        assert range_rows_digest(session, changed, 0.15) != digest
    # the NaN row is not a range: the digest counts it as a row of the table only
    with_nan = pd.concat([frame, frame.iloc[[7]].assign(range=np.nan)])
    assert range_rows_digest(session, with_nan, 0.15).split("-")[:2] == digest.split("-")[:2]


def test_a_set_with_the_observed_ranges_gets_the_observed_fusion(session) -> None:
    params = FusionParams(state="position")  # the NIS rounds inflate: notes to relabel
    frame = _observed(session)
    observed = fusion_stage(
        PositionInput(session, "observed", frame, "ranges", want_cp=True), params
    )
    assert observed.calibration.drift_scale  # the notes to relabel are there
    assert observed.notes and all(n.startswith("fusion (observed): ") for n in observed.notes)
    same = _pair_major(frame)
    reused = fusion_stage(PositionInput(session, "rn", same, "ranges", observed=observed), params)
    for pid, trajectory in observed.positions.items():
        assert reused.positions[pid] is trajectory
    assert reused.positions is not observed.positions
    assert reused.notes[-1].startswith("fusion (rn): the rn ranges are the observed ones")
    assert reused.notes[:-1] == tuple(
        n.replace("fusion (observed): ", "fusion (rn): ") for n in observed.notes
    )
    assert reused.calibration.pair_sigma_m == observed.calibration.pair_sigma_m
    assert reused.calibration.drift_scale == observed.calibration.drift_scale
    # what running it gives (the observed product without its digest is not reused): the
    # same fusion, with the observed sigmas as floor: bit for bit when the rows are listed
    # alike, to rounding when pair by pair (the order of the rows' sums)
    blind = dataclasses.replace(
        observed, calibration=dataclasses.replace(observed.calibration, range_digest="")
    )
    for listing, exact in ((frame, True), (same, False)):
        computed = fusion_stage(
            PositionInput(session, "rn", listing, "ranges", observed=blind), params
        )
        assert computed.notes == reused.notes[:-1]
        for name in ("pair_sigma_m", "drift_scale"):
            got, want = getattr(computed.calibration, name), getattr(reused.calibration, name)
            assert got == (want if exact else pytest.approx(want, rel=1e-12))
        for pid, trajectory in computed.positions.items():
            assert np.array_equal(trajectory.time_s, reused.positions[pid].time_s)
            if exact:
                assert np.array_equal(trajectory.enu_m, reused.positions[pid].enu_m)
            else:
                np.testing.assert_allclose(trajectory.enu_m, reused.positions[pid].enu_m, atol=1e-9)


def test_a_set_with_one_range_changed_is_fused(session) -> None:
    params = FusionParams()
    frame = _observed(session)
    observed = fusion_stage(
        PositionInput(session, "observed", frame, "ranges", want_cp=True), params
    )
    moved = _pair_major(frame)
    moved.loc[len(moved) // 2, "range"] += 0.5
    fused = fusion_stage(PositionInput(session, "di", moved, "ranges", observed=observed), params)
    assert not any("reused" in n for n in fused.notes)
    assert any(
        not np.array_equal(fused.positions[p].enu_m, observed.positions[p].enu_m)
        for p in observed.positions
    )
