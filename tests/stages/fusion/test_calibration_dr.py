"""The followers' DR noise factor by leave-pair-out cross-validation (calibration_dr.py):
it tightens the figures where the ranges' left-out pairs say so, on sample_logs (the
simulator's paper-experiment, whose dead reckoning is 2-3 deg/h and 0.2-0.6 %: far
better than the default figures), and through `coopproc run` the observed fusion gets the
error that factor buys."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.checks.coverage import prepare_run
from coopproc.cli import main
from coopproc.io import read_session
from coopproc.stages.fusion.calibration_dr import dr_noise_cv
from coopproc.stages.fusion.fuse import fuse
from coopproc.stages.fusion.params import FusionParams

SAMPLE = Path(__file__).resolve().parents[3] / "sample_logs"


@pytest.fixture(scope="module")
def sample() -> tuple[object, pd.DataFrame]:
    session, _ = prepare_run(read_session(SAMPLE))
    return session, session.ranges.frame[["time", "from", "to", "range", "sigma"]]


def test_the_cv_tightens_a_dead_reckoning_better_than_its_figures(sample: tuple) -> None:
    session, ranges = sample
    params = FusionParams()  # dr_noise_cv = true, the default
    factor, scores = dr_noise_cv(session, ranges, params, list(session.moving_platforms()))
    # measured 0.03125 (0.0716 m), 1/16 0.0726, 1/4 0.0919, 1 0.1278 m: monotone
    assert factor <= 1.0 / 16.0
    assert set(scores) >= {1.0 / 16.0, 0.25, 1.0} and max(scores) == 1.0  # never loosens
    assert scores[1.0] > 1.5 * scores[factor]
    assert scores[0.25] > scores[1.0 / 16.0]
    # off, the position state, or one pair: no search
    off = FusionParams(dr_noise_cv=False)
    assert dr_noise_cv(session, ranges, off, ["A", "B", "C"]) == (1.0, {})
    position = dataclasses.replace(params, state="position")
    assert dr_noise_cv(session, ranges, position, ["A", "B", "C"]) == (1.0, {})
    one_pair = ranges[(ranges["from"] == "A") & (ranges["to"] == "B")]
    assert dr_noise_cv(session, one_pair, params, ["A", "B", "C"]) == (1.0, {})


def test_a_fusion_without_dr_states_has_the_same_positions(sample: tuple) -> None:
    # the CV's fusions skip the DR states' report (dr_states=False): the same bits
    session, ranges = sample
    params = FusionParams()
    with_dr = fuse(session, ranges, params, smoothed_sigma=False, forward=False)
    without = fuse(session, ranges, params, smoothed_sigma=False, forward=False, dr_states=False)
    assert with_dr.dr_states is not None and len(with_dr.dr_states) > 0
    assert without.dr_states is None
    assert set(with_dr.smoothed) == set(without.smoothed) == {"A", "B", "C"}
    for pid, track in with_dr.smoothed.items():
        assert np.array_equal(track.enu_m, without.smoothed[pid].enu_m)
    assert with_dr.observations.equals(without.observations)


def test_a_refit_that_changes_no_factor_does_not_smooth_again(
    sample: tuple, monkeypatch: pytest.MonkeyPatch
) -> None:
    # where the robust refit keeps every factor, the smoother's second pass would be the
    # first's: without DR states or sigmas it is not run; with them it is, the same bits
    import coopproc.stages.fusion.fuse as fuse_mod

    session, ranges = sample
    params = FusionParams()
    real = fuse_mod.smoothed_gammas

    def keep(obs, *args):  # type: ignore[no-untyped-def]
        _, resid, std = real(obs, *args)
        return args[5].copy(), resid, std  # the factors as they were (args[5]: gamma)

    calls: list[bool] = []
    smoother = fuse_mod.mbf_backward

    def count(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(True)
        return smoother(*args, **kwargs)

    monkeypatch.setattr(fuse_mod, "smoothed_gammas", keep)
    monkeypatch.setattr(fuse_mod, "mbf_backward", count)
    once = fuse(session, ranges, params, smoothed_sigma=False, forward=False, dr_states=False)
    assert len(calls) == 1
    again = fuse(session, ranges, params, smoothed_sigma=False, forward=False)
    assert len(calls) == 3  # the DR states asked: the second pass runs
    for pid, track in again.smoothed.items():
        assert np.array_equal(track.enu_m, once.smoothed[pid].enu_m)


def test_the_cv_factor_through_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(SAMPLE), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "dead-reckoning noise is 0.03125 x the [fusion] figures (the factor whose" in (
        res.output
    )
    # every processed set takes the observed ranges' factor: RN's ranges are the observed
    # ones less its estimates, DI's are smoothed with the same dead reckoning (with the
    # [fusion] figures instead, paper-experiment seed 2 at 15 min had DI-fused 2.7 x
    # observed-fused: tests/e2e/test_e2e_di_fused.py)
    assert "fusion (rn): the followers' dead-reckoning noise is 0.03125 x" in res.output
    assert "fusion (di): the followers' dead-reckoning noise is 0.03125 x" in res.output
    pos = pd.read_csv(out / "positions.csv")
    mean = pos.groupby(["platform", "method"])["error_h"].mean()
    # 0.132 / 0.140 m with the default figures (a GTSAM factor graph: 0.077 / 0.094 m)
    assert mean[("A", "observed")] < 0.05 and mean[("C", "observed")] < 0.06
    assert mean[("A", "di")] < mean[("A", "observed")]
