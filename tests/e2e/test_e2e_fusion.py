"""Issue 5 acceptance: cooperative fusion with processed ranges against simulated truth
(paper 000 Table 3), through real files and `coopproc run`."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from tests.e2e.conftest import E2ERun


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_experiment_table3(e2e_runs: Callable[[str, int], E2ERun], seed: int) -> None:
    run = e2e_runs("paper-experiment", seed)
    followers = ["A", "C"]
    for platform in followers:
        nav = run.position(platform, "nav", "mean")
        observed = run.position(platform, "observed", "mean")
        rn = run.position(platform, "rn", "mean")
        di = run.position(platform, "di", "mean")
        print(f"\n{platform}: nav {nav:.3f}  observed {observed:.3f}  rn {rn:.3f}  di {di:.3f}")
        # paper 000 Table 3: DI -55 % / -58 %; the observed fusion is much better here
        # (DR states, their noise by the cross-validation): measured 0.63 / 0.48 x on seed
        # 0 (A / C), 0.75 / 0.64 x on seed 1
        assert di <= 0.8 * observed, (platform, di, observed)
        assert di < rn, (platform, di, rn)
        for method in ("observed", "rn", "di"):
            assert run.position(platform, method, "mean") < nav, (platform, method)


def _fused_mean_errors(run: E2ERun, column: str) -> dict[str, float]:
    """Mean horizontal error of each follower when the session is fused (self-calibrated,
    as coopproc run fuses) with the distances of one column of the run's ranges.csv
    (``reference``: perfect ranges)."""
    import numpy as np
    import pandas as pd

    from coopproc.io import read_session
    from coopproc.model import pair_members
    from coopproc.run.config import RunConfig
    from coopproc.stages.fusion.calibration import calibrated_fuse

    session = read_session(run.session)
    rows = run.ranges[np.isfinite(run.ranges[column])]
    members = [pair_members(p) for p in rows["pair"]]
    ranges = pd.DataFrame(
        {
            "time": rows["time"].to_numpy(),
            "from": [a for a, _ in members],
            "to": [b for _, b in members],
            "range": rows[column].to_numpy(),
            "sigma": session.config.uwb_sigma_m,
        }
    )
    # smoothed ranges (DI) keep the [fusion] DR figures, as the run fuses them; others get
    # the cross-validation's factor (calibration_dr.py)
    factor = 1.0 if column == "di" else None
    fused, _ = calibrated_fuse(session, ranges, RunConfig().fusion, dr_factor=factor)
    out = {}
    for platform in ("A", "C"):
        traj = fused.smoothed[platform]
        ref = session.reference[platform].interpolate_within(traj.time_s)
        out[platform] = float(np.nanmean(np.hypot(*(traj.enu_m[:, :2] - ref[:, :2]).T)))
    return out


@pytest.mark.parametrize("seed", [2, 3])
def test_di_fusion_reaches_the_perfect_range_bound(
    e2e_runs: Callable[[str, int], E2ERun], seed: int
) -> None:
    """The DI-Based fusion beats observed and RN and comes near fusion with the true
    distances. With the followers' heading and scale in the state the dead-reckoning floor
    is low (perfect ranges: 0.021 / 0.024 m for A on seeds 2 / 3, 0.04-0.05 m with the
    position-only state), so DI's own range errors show: DI 0.032 / 0.036 m, within 60 %."""
    run = e2e_runs("paper-experiment", seed)
    perfect = _fused_mean_errors(run, "reference")
    same_way = _fused_mean_errors(run, "di")  # the DI fusion at the same epochs as perfect
    for platform in ("A", "C"):
        observed = run.position(platform, "observed", "mean")
        di = run.position(platform, "di", "mean")
        print(f"\n{platform}: observed {observed:.3f} di {di:.3f} perfect {perfect[platform]:.3f}")
        if (seed, platform) == (2, "C"):
            # the known exception since the DI fusion takes the observed fusion's DR noise
            # factor (1/32; docs/methods-fusion.md#dr-noise-cv): 0.048 m against 0.038 m
            # observed-fused (0.034 m on the [fusion] figures, which give 2.9 x at 15 min)
            assert di <= 1.3 * observed
            assert same_way[platform] <= 0.05, (platform, same_way)
            continue
        assert di < observed
        assert di <= run.position(platform, "rn", "mean") + 0.005
        assert same_way[platform] <= 1.6 * perfect[platform], (platform, same_way, perfect)
        assert same_way[platform] <= 0.045, (platform, same_way)
