"""A fusion's prepared inputs, shared by the self-calibration's fusions (issue 11): a
fusion of other sigmas, range values or output from shared inputs is bit for bit a fresh
one."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
import pytest

from coopproc.sim import simulate
from coopproc.stages.fusion.fuse import FusionOutput, FusionParams, fuse
from coopproc.stages.fusion.inputs import fusion_inputs
from coopproc.stages.fusion.output import recorded_slots


def _same(a: FusionOutput, b: FusionOutput) -> None:
    assert a.observations.equals(b.observations)
    assert np.array_equal(a.epochs_s, b.epochs_s)
    for pid in a.smoothed:
        for x, y in ((a.smoothed[pid], b.smoothed[pid]), (a.forward[pid], b.forward[pid])):
            assert np.array_equal(x.time_s, y.time_s)
            assert np.array_equal(x.enu_m, y.enu_m)
            assert np.array_equal(x.sigma_enu_m, y.sigma_enu_m, equal_nan=True)


def _other(frame: pd.DataFrame, platform: str) -> pd.DataFrame:
    """Other sigmas for every row, ``platform``'s ranges 0.2 m shorter."""
    rows = ((frame["from"] == platform) | (frame["to"] == platform)).to_numpy()
    value = frame["range"].to_numpy(dtype=np.float64) - np.where(rows, 0.2, 0.0)
    sigma = np.where(rows, 0.4, 0.12)
    sigma[::7] = np.nan  # the default sigma for some
    return frame.assign(range=value, sigma=sigma)


@pytest.mark.parametrize("scenario", ["dr-faults", "anchors"])
def test_with_ranges_is_a_fresh_fusion(scenario: str) -> None:
    session = simulate(scenario, seed=0, duration_s=40.0).session
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    params = FusionParams()
    inputs = fusion_inputs(session, frame, params)
    other = _other(frame, session.ranges.frame["to"].iloc[0])
    shared = inputs.with_ranges(other)
    assert shared.obs["kind"] is inputs.obs["kind"]  # the structure is shared, not rebuilt
    assert not np.array_equal(shared.obs["var"], inputs.obs["var"])
    scale = {next(iter(session.moving_platforms())): 2.0}
    _same(fuse(session, other, params, drift_scale=scale, inputs=shared),
          fuse(session, other, params, drift_scale=scale))  # fmt: skip
    # the first inputs are untouched by the second's
    _same(fuse(session, frame, params, inputs=inputs), fuse(session, frame, params))
    nav = inputs.with_ranges(other, "nav")
    _same(fuse(session, other, params, output="nav", inputs=nav),
          fuse(session, other, params, output="nav"))  # fmt: skip


def test_with_ranges_of_other_rows_prepares_afresh() -> None:
    session = simulate("dr-faults", seed=0, duration_s=30.0).session
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    params = FusionParams()
    inputs = fusion_inputs(session, frame, params)
    value = frame["range"].to_numpy(dtype=np.float64).copy()
    value[::5] = np.nan  # dropouts: other rows are kept
    fewer = frame.assign(range=value)
    again = inputs.with_ranges(fewer)
    assert again.obs["kind"] is not inputs.obs["kind"]
    assert again.epochs.shape[0] < inputs.epochs.shape[0]
    _same(fuse(session, fewer, params, inputs=again), fuse(session, fewer, params))
    with pytest.raises(ValueError, match="another session"):
        fuse(session, frame, params, output="nav", inputs=inputs)


def _slots_naive(session, ranges, moving, epochs):
    """The recorded slots as first written: both searches, both tables."""
    n_ep, n_plat = epochs.shape[0], len(moving)
    wanted = np.zeros(n_ep * n_plat, dtype=bool)
    wanted[:n_plat] = True
    wanted[(n_ep - 1) * n_plat :] = True
    for frame in (session.ranges.frame, ranges):
        t = frame["time"].to_numpy(np.float64)
        right = np.clip(np.searchsorted(epochs, t, side="right") - 1, 0, n_ep - 1)
        left = np.clip(np.searchsorted(epochs, t, side="left"), 0, n_ep - 1)
        for column in ("from", "to"):
            code = np.array([moving.index(p) if p in moving else -1 for p in frame[column]])
            sel = np.isfinite(t) & (code >= 0)
            wanted[right[sel] * n_plat + code[sel]] = True
            wanted[left[sel] * n_plat + code[sel]] = True
    unique = np.flatnonzero(wanted)
    ptr = np.concatenate(([0], np.cumsum(np.bincount(unique // n_plat, minlength=n_ep))))
    return ptr, unique % n_plat


def test_recorded_slots_one_search() -> None:
    session = simulate("dr-faults", seed=0, duration_s=20.0).session
    frame = session.ranges.frame
    moving = list(session.moving_platforms())
    times = np.unique(frame["time"].to_numpy(np.float64))
    epochs = times[::3]  # most range times between two epochs, some on one
    late = frame.assign(time=frame["time"] + 0.013)  # none on an epoch, some past the last
    late.loc[late.index[:4], "time"] = np.nan
    for ranges in (frame[["time", "from", "to", "range"]], late):
        ptr, plat = recorded_slots(session, ranges, moving, epochs, False)
        want_ptr, want_plat = _slots_naive(session, ranges, moving, epochs)
        assert np.array_equal(ptr, want_ptr) and np.array_equal(plat, want_plat)


def _fused_twice(**lean: bool) -> tuple[Any, Any, Any, Any]:
    """calibrated_fuse of the dr-faults session as the run's tables take it (no smoothed
    sigmas), then with the options ``lean``: both results and calibrations."""
    from coopproc.stages.fusion.calibration import calibrated_fuse

    session = simulate("dr-faults", seed=0, duration_s=40.0).session
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    full, cal_full = calibrated_fuse(session, frame, FusionParams(), smoothed_sigma=False)
    less, cal_less = calibrated_fuse(session, frame, FusionParams(), smoothed_sigma=False, **lean)
    return full, cal_full, less, cal_less


def test_without_the_forward_trajectories_the_smoothed_are_the_same() -> None:
    # fusion (rn) / (di) read the smoothed solution only: the forward one is not built
    both, cal_both, smoothed, cal = _fused_twice(forward=False)
    assert smoothed.forward == {} and len(both.forward) == len(both.smoothed) > 1
    assert cal == cal_both
    for pid, track in both.smoothed.items():
        assert np.array_equal(track.enu_m, smoothed.smoothed[pid].enu_m)
        assert np.array_equal(track.time_s, smoothed.smoothed[pid].time_s)


def test_forward_trajectories_without_sigmas_have_the_same_positions() -> None:
    # the ranging stage reads the CP solution's positions only (issue 11: 24 bytes a slot)
    full, _, lean, _ = _fused_twice(forward_sigma=False)
    assert set(lean.forward) == set(full.forward) and len(full.forward) > 1
    for pid, track in full.forward.items():
        assert track.sigma_enu_m is not None and np.isfinite(track.sigma_enu_m[:, :2]).all()
        assert lean.forward[pid].sigma_enu_m is None
        assert np.array_equal(track.enu_m, lean.forward[pid].enu_m)
        assert np.array_equal(track.time_s, lean.forward[pid].time_s)
    for pid, track in full.smoothed.items():
        assert np.array_equal(track.enu_m, lean.smoothed[pid].enu_m)


def test_a_discarded_fusion_without_forward_trajectories_keeps_only_its_table() -> None:
    # a drift round to be refitted reads the innovations only: no states are kept for it
    session = simulate("dr-faults", seed=0, duration_s=40.0).session
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    kept = fuse(session, frame, FusionParams(), discard=lambda table: True)
    dropped = fuse(session, frame, FusionParams(), discard=lambda table: True, forward=False)
    assert dropped.smoothed == {} and dropped.forward == {}
    assert len(kept.smoothed) > 1  # with forward=True it is the forward solution
    assert dropped.observations.equals(kept.observations)
    assert np.array_equal(dropped.epochs_s, kept.epochs_s)
