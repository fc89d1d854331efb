"""The self-calibration skips the smoother of fusions it refits (issue 11), bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.sim import simulate
from coopproc.stages.fusion import calibration
from coopproc.stages.fusion import fuse as fuse_module
from coopproc.stages.fusion.fuse import FusionParams, fuse
from tests.stages.fusion.test_fusion import make_session


@pytest.fixture(scope="module")
def base():
    return make_session(duration_s=200.0)


def test_discard_skips_only_the_smoother(base) -> None:
    session, _, _ = base
    frame = session.ranges.frame
    plain = fuse(session, frame, FusionParams(), smoothed_sigma=False)
    kept = fuse(session, frame, FusionParams(), smoothed_sigma=False, discard=lambda t: False)
    dropped = fuse(session, frame, FusionParams(), smoothed_sigma=False, discard=lambda t: True)
    assert plain.observations.equals(dropped.observations)
    for pid in plain.smoothed:
        assert np.array_equal(plain.smoothed[pid].enu_m, kept.smoothed[pid].enu_m)
        assert np.array_equal(plain.forward[pid].enu_m, dropped.forward[pid].enu_m)
        assert np.array_equal(dropped.smoothed[pid].enu_m, dropped.forward[pid].enu_m)
    assert not np.array_equal(plain.smoothed["A"].enu_m, plain.forward["A"].enu_m)


def test_drift_rounds_smooth_only_the_fusion_returned(monkeypatch) -> None:
    # dr-faults: heading drifts the declared sigmas do not cover, so the NIS test inflates
    # the drifts over several rounds
    session = simulate("dr-faults", seed=0, duration_s=60.0).session
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    params = FusionParams(state="position")  # with DR states the heading is in the state
    calls = {"smoother": 0, "fusions": 0}
    real_smoother, real_fuse = fuse_module.mbf_backward, calibration.fuse

    def counting_smoother(*args, **kwargs):
        calls["smoother"] += 1
        return real_smoother(*args, **kwargs)

    def counting_fuse(*args, **kwargs):
        calls["fusions"] += 1
        return real_fuse(*args, **kwargs)

    monkeypatch.setattr(fuse_module, "mbf_backward", counting_smoother)
    monkeypatch.setattr(calibration, "fuse", counting_fuse)
    fused, scale, _ = calibration._drift_scales(session, frame, params, {})
    assert calls["fusions"] >= 2 and scale  # refitted at least once
    assert calls["smoother"] == 1  # only the fusion that is returned was smoothed
    again = real_fuse(session, frame, params, drift_scale=scale)
    for pid in again.smoothed:
        assert np.array_equal(fused.smoothed[pid].enu_m, again.smoothed[pid].enu_m)
        assert not np.array_equal(fused.smoothed[pid].enu_m, fused.forward[pid].enu_m)
    assert fused.observations.equals(again.observations)
