"""The locate stage on in-memory sessions with known truth (paper 004 sections 4-5)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import ConfigError, StageError
from coopproc.stages.particle import (
    LOCATE_COLUMNS,
    LOCATE_SUMMARY_COLUMNS,
    LocateParams,
    locate,
    locate_params,
)

# 40 ring positions x 120 azimuths: small enough for a fast test, fine enough to converge
SMALL = {"N": 40, "M": 120, "seed": 2}


@pytest.fixture(scope="module")
def moving(single_aux_session):
    session, heading0 = single_aux_session(seed=1)
    return session, heading0, locate(session, "T", ["A1"], locate_params(SMALL))


def test_tables_follow_the_data_contract(moving) -> None:
    _, _, result = moving
    assert tuple(result.table.columns) == LOCATE_COLUMNS
    assert tuple(result.summary.columns) == LOCATE_SUMMARY_COLUMNS
    assert list(result.summary["method"]) == ["aacopf", "pf", "ekf"]
    n = result.inputs.n_epochs
    assert len(result.table) == 3 * n
    heading = result.table["heading"].to_numpy()
    assert np.all((heading >= 0) & (heading < 360))


def test_moving_auxiliary_converges(moving) -> None:
    _, heading0, result = moving
    s = result.summary.set_index("method")
    assert s.loc["aacopf", "observable"] == 1
    err = {m: result.table[result.table["method"] == m]["error_h"].to_numpy() for m in s.index}
    assert err["aacopf"][0] > 5.0  # no prior: it starts anywhere on the ring
    assert np.max(err["aacopf"][-60:]) < 0.5  # and tracks once observable
    assert abs(s.loc["aacopf", "azimuth_error"]) < 1.0  # acceptance: < 1 deg
    assert s.loc["aacopf", "converged_at"] < 60.0
    # the standard PF converges too, less tightly (no regularized moves: with process
    # noise sized like the dead reckoning, its copies barely separate)
    assert err["pf"][-1] < 1.0 and abs(s.loc["pf", "azimuth_error"]) < 3.0
    # the reference initial azimuth is the simulated truth
    assert result.reference_initial_azimuth_deg == pytest.approx(heading0[0], abs=0.5)
    assert abs(s.loc["aacopf", "initial_azimuth"] - heading0[0]) < 1.5


def test_observability_of_the_run(moving) -> None:
    _, _, result = moving
    obs = result.observability
    s1, s2, s3 = obs.singular_values
    assert s1 >= s2 >= s3 > 5e-3 * s1
    assert obs.observable_from is not None and obs.observable_from < 30
    assert not result.warnings


def test_static_auxiliary_is_unobservable(single_aux_session) -> None:
    session, _ = single_aux_session(seed=3, aux_motion="static", duration_s=80.0)
    params = locate_params({**SMALL, "methods": ["aacopf", "ekf"]})
    result = locate(session, "T", ["A1"], params)
    s1, _, s3 = result.observability.singular_values
    assert s3 < 1e-3 * s1
    assert (result.summary["observable"] == 0).all()
    assert result.summary["converged_at"].isna().all()  # no convergence claim
    assert any("not observable" in w for w in result.warnings)


def test_same_direction_auxiliary_is_unobservable(single_aux_session) -> None:
    session, _ = single_aux_session(seed=3, aux_motion="same", duration_s=80.0)
    params = locate_params({**SMALL, "methods": ["pf"]})
    result = locate(session, "T", ["A1"], params)
    assert (result.summary["observable"] == 0).all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_biased_second_auxiliary_is_rejected_and_aacopf_beats_pf(
    single_aux_session, seed: int
) -> None:
    """Paper 004 section 5.2: A2 has a peak shift (+1.5 m) and exponential (non-Gaussian)
    ranging errors."""
    session, _ = single_aux_session(seed=5, biased_second=True)
    params = locate_params({"N": 60, "M": 60, "seed": seed, "methods": ["aacopf", "pf"]})
    result = locate(session, "T", ["A1", "A2"], params)
    rejected = result.tracks["aacopf"].rejected
    assert rejected is not None
    has = np.isfinite(result.inputs.range_m)
    assert rejected[:, 1][has[:, 1]].mean() > 0.7  # A2 out most of the time
    assert rejected[:, 0].mean() < 0.05  # A1 kept
    s = result.summary.set_index("method")
    assert s.loc["aacopf", "rmse_h"] < s.loc["pf", "rmse_h"]
    err = {m: result.table[result.table["method"] == m]["error_h"].to_numpy() for m in s.index}
    assert np.max(err["aacopf"][-100:]) < 0.6
    assert np.max(err["pf"][-100:]) > 1.0  # the PF follows the biased ranges
    assert any("'A2' rejected" in w for w in result.warnings)


def test_deterministic_by_seed(single_aux_session) -> None:
    session, _ = single_aux_session(seed=1, duration_s=40.0)
    params = locate_params({"N": 20, "M": 20, "seed": 7})
    one = locate(session, "T", ["A1"], params).table
    two = locate(session, "T", ["A1"], params).table
    pd.testing.assert_frame_equal(one, two)
    other = locate(session, "T", ["A1"], locate_params({"N": 20, "M": 20, "seed": 8})).table
    assert not one[one["method"] == "aacopf"].equals(other[other["method"] == "aacopf"])


def test_ekf_runs_from_a_coarse_guess(moving) -> None:
    _, _, result = moving
    ekf = result.table[result.table["method"] == "ekf"]
    assert np.isfinite(ekf[["east", "north", "heading"]].to_numpy()).all()
    # the default bank of 16 x 16 EKFs (initial bearings x azimuths) converges
    assert np.max(ekf["error_h"].to_numpy()[-60:]) < 0.5
    assert abs(result.summary.set_index("method").loc["ekf", "azimuth_error"]) < 1.0


def test_a_single_coarse_ekf_does_not_converge(single_aux_session) -> None:
    session, _ = single_aux_session(seed=1)
    params = locate_params(
        {"methods": ["ekf"], "ekf_bearings": 1, "ekf_azimuths": 1, "ekf_initial_azimuth_deg": 200}
    )
    result = locate(session, "T", ["A1"], params)
    assert np.min(result.table["error_h"].to_numpy()[-60:]) > 2.0


def test_bad_requests_are_one_line_errors(single_aux_session) -> None:
    session, _ = single_aux_session(seed=1, duration_s=20.0)
    p = LocateParams(N=5, M=5)
    with pytest.raises(StageError, match="'X' has no navigation"):
        locate(session, "X", ["A1"], p)
    with pytest.raises(StageError, match="own auxiliary"):
        locate(session, "T", ["T"], p)
    with pytest.raises(StageError, match="at least one auxiliary"):
        locate(session, "T", [], p)


def test_params_from_toml_table() -> None:
    p = locate_params({"lambda": 0.2, "Omega1": 0.5, "methods": ["pf"]})
    assert p.lambda_ == 0.2 and p.Omega1 == 0.5 and p.methods == ("pf",)
    with pytest.raises(ConfigError, match="did you mean 'alpha'"):
        locate_params({"alpah": 1.0})
    with pytest.raises(ConfigError, match="methods"):
        locate_params({"methods": ["kalman"]})
    with pytest.raises(ConfigError, match="N and M"):
        locate_params({"N": 0})
