"""The self-calibration on long sessions (issue 11): the platform range-bias decision is an
effect size (it does not flag ever smaller biases as the session grows), and above a cap
the calibration rounds fuse a bounded, evenly thinned, deterministic subset of the ranges."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.model import pair_name
from coopproc.stages.fusion import calibration, calibration_bias
from coopproc.stages.fusion.calibration_bias import BIAS_EFFECT, biased_platform
from coopproc.stages.fusion.calibration_subset import calibration_rows
from coopproc.stages.fusion.fuse import FusionParams
from tests.stages.fusion.test_fusion import make_session

PLATFORMS = ["P0", "P1", "P2", "P3", "P4"]


def _network(n_per_pair: int, seed: int = 0) -> pd.DataFrame:
    """Every pair of five platforms ranging ``n_per_pair`` times, given sigma 0.15 m."""
    pairs = [(a, b) for i, a in enumerate(PLATFORMS) for b in PLATFORMS[i + 1 :]]
    frm = np.repeat([a for a, _ in pairs], n_per_pair)
    to = np.repeat([b for _, b in pairs], n_per_pair)
    return pd.DataFrame({"from": frm, "to": to, "sigma": 0.15, "seed": seed})


def _residuals(frame: pd.DataFrame, spread_p4: float, bias_p4: float, seed: int) -> np.ndarray:
    """Residuals of 0.08 m noise; P4's ranges with extra spread and a bias."""
    rng = np.random.default_rng(seed)
    p4 = (frame["from"].to_numpy() == "P4") | (frame["to"].to_numpy() == "P4")
    resid = rng.normal(0.0, 0.08, len(frame))
    resid[p4] = rng.normal(bias_p4, spread_p4, int(p4.sum()))
    return resid


def _sigmas(spread_p4: float) -> dict[str, float]:
    """Pair sigmas as the calibration would use them: P4's pairs inflated."""
    out = {}
    for i, a in enumerate(PLATFORMS):
        for b in PLATFORMS[i + 1 :]:
            out[pair_name(a, b)] = spread_p4 if "P4" in (a, b) else 0.15
    return out


@pytest.mark.parametrize("n_per_pair", [100, 10_000])
def test_no_bias_estimated_on_an_unbiased_platform_however_long(n_per_pair: int) -> None:
    # P4's ranges scatter 3x more (its pairs' sigma 3 x the others', the RMS test flags
    # it) but are not biased: no bias iteration, for a short and a 100x longer session
    frame = _network(n_per_pair)
    resid = _residuals(frame, spread_p4=0.45, bias_p4=0.0, seed=1)
    given = frame["sigma"].to_numpy(dtype=np.float64)
    assert calibration_bias.platform_range_factor(_sigmas(0.45)) == {"P4": 3.0}
    assert biased_platform(_sigmas(0.45), resid, frame, given) == {}


@pytest.mark.parametrize("n_per_pair", [100, 10_000])
def test_a_bias_that_matters_is_estimated_whatever_the_length(n_per_pair: int) -> None:
    frame = _network(n_per_pair)
    given = frame["sigma"].to_numpy(dtype=np.float64)
    biased = _residuals(frame, spread_p4=0.45, bias_p4=0.15, seed=2)  # 1 x sigma
    assert biased_platform(_sigmas(0.45), biased, frame, given) == {"P4": 3.0}
    # below the effect size: not estimated, even with 10,000 ranges per pair, where a
    # significance test would call a 0.02 m offset certain
    small = _residuals(frame, spread_p4=0.45, bias_p4=0.02, seed=3)
    assert BIAS_EFFECT * 0.15 > 0.02
    assert biased_platform(_sigmas(0.45), small, frame, given) == {}


def test_relative_bias_ignores_a_network_wide_offset() -> None:
    frame = _network(200)
    resid = _residuals(frame, spread_p4=0.08, bias_p4=0.3, seed=4) - 0.5
    assert calibration_bias.relative_bias(resid, frame, "P4") == pytest.approx(0.3, abs=0.02)
    # a platform sharing one biased pair of four is not itself biased
    assert abs(calibration_bias.relative_bias(resid, frame, "P0")) < 0.15


def _biased_session(bias: float):
    session, _, _ = make_session(duration_s=240.0, followers=4, seed=3)
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]].copy()
    # A is ranged from all sides (D, behind the others, is not: its bias would be taken
    # for a position)
    a = (frame["from"] == "A") | (frame["to"] == "A")
    frame.loc[a, "range"] += bias
    return session, frame


@pytest.mark.parametrize("bias", [0.0, 0.5])
def test_calibrated_fuse_corrects_a_real_platform_bias_only(bias: float) -> None:
    session, frame = _biased_session(bias)
    _, cal = calibration.calibrated_fuse(session, frame, FusionParams(), smoothed_sigma=False)
    noted = [n for n in cal.notes if "disagree with the rest" in n]
    if bias:
        assert len(noted) == 1 and "the ranges of A " in noted[0], cal.notes
        found = float(noted[0].split(" read ")[1].split(" m long")[0])
        assert found == pytest.approx(bias, abs=0.1)
    else:
        assert noted == []


def test_calibration_rows_none_at_or_below_the_cap() -> None:
    times = np.repeat(np.arange(1000.0), 3)
    assert calibration_rows(times, None) is None
    assert calibration_rows(times, 1000) is None
    assert calibration_rows(times, 5000) is None
    with pytest.raises(ValueError):
        calibration_rows(times, 0)


@pytest.mark.parametrize(("n", "cap"), [(1001, 1000), (10_000, 999), (5000, 3), (90_000, 30_000)])
def test_calibration_rows_bounded_and_spread(n: int, cap: int) -> None:
    rng = np.random.default_rng(n)
    epochs = np.cumsum(rng.uniform(0.01, 0.05, n))
    times = np.repeat(epochs, 2)  # two ranges at every time: kept or dropped together
    rows = calibration_rows(times, cap)
    assert rows is not None
    assert np.all(np.diff(rows) > 0)
    kept = np.unique(times[rows])
    assert cap - 3 <= kept.shape[0] <= cap
    assert rows.shape[0] == 2 * kept.shape[0]
    # every tenth of the session keeps its share of the epochs
    index = np.searchsorted(epochs, kept)
    share = np.bincount(index * 10 // n, minlength=10) / kept.shape[0]
    assert np.all(np.abs(share - 0.1) <= 0.1 * 0.1 + 2.0 / kept.shape[0]), share


@pytest.mark.parametrize("step", [3, 4, 45])
def test_calibration_rows_keep_every_pair_of_a_polling_round(step: int) -> None:
    # 45 pairs polled in turn (epoch i is pair i mod 45); a cap of 1/step of the epochs
    # keeps every pair's share (every step-th epoch would keep 45 / gcd(step, 45) pairs)
    n = 45 * 400
    pair = np.arange(n) % 45
    rows = calibration_rows(np.arange(n) * 0.0222, n // step)
    assert rows is not None
    counts = np.bincount(pair[rows], minlength=45)
    assert counts.min() >= 0.85 * 400 / step and counts.max() <= 1.15 * 400 / step + 1


def test_calibration_rows_depend_on_the_times_only() -> None:
    rng = np.random.default_rng(5)
    times = np.repeat(np.arange(3000.0) * 0.1, 3)
    order = rng.permutation(times.shape[0])
    rows = calibration_rows(times, 600)
    shuffled = calibration_rows(times[order], 600)
    assert rows is not None and shuffled is not None
    assert np.array_equal(np.sort(times[rows]), np.sort(times[order][shuffled]))
    assert np.array_equal(rows, calibration_rows(times, 600))


def test_bias_iteration_fuses_the_subset_and_the_rest_every_range(monkeypatch) -> None:
    session, frame = _biased_session(0.5)
    seen: dict[str, list[int]] = {"calibration": [], "bias": []}

    def counting(where: str, real):
        def fuse(session_, ranges, *args, **kwargs):
            seen[where].append(len(ranges))
            return real(session_, ranges, *args, **kwargs)

        return fuse

    monkeypatch.setattr(calibration, "fuse", counting("calibration", calibration.fuse))
    monkeypatch.setattr(calibration_bias, "fuse", counting("bias", calibration_bias.fuse))
    cap = 120  # of 239 range times
    rows = calibration_rows(frame["time"].to_numpy(), cap)
    assert rows is not None
    out, cal = calibration.calibrated_fuse(
        session, frame, FusionParams(), smoothed_sigma=False, max_epochs=cap
    )
    # the iteration on the subset, then one step on every range
    assert len(seen["bias"]) >= 3 and set(seen["bias"][:-1]) == {rows.shape[0]}
    assert seen["bias"][-1] == len(frame)
    assert len(seen["calibration"]) >= 2 and set(seen["calibration"]) == {len(frame)}
    assert out.epochs_s.shape[0] == np.unique(frame["time"]).shape[0]
    noted = [n for n in cal.notes if "the ranges of A " in n]
    assert len(noted) == 1
    found = float(noted[0].split(" read ")[1].split(" m long")[0])
    assert found == pytest.approx(0.5, abs=0.1)
