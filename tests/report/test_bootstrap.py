"""The block bootstrap (report/bootstrap.py, report/intervals.py): block lengths of known
processes, prefix sums equal to resampling epochs, coverage and false-alarm rates on
AR(1) errors, determinism."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from coopproc.report.bootstrap import (
    Blocks,
    block_length,
    draw_blocks,
    generator,
    resampled_sums,
    variance_ratio,
)
from coopproc.report.comparisons import distance_comparisons
from coopproc.report.intervals import distance_intervals, paired_difference, position_intervals


def _ar1(n: int, phi: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance AR(1)."""
    return lfilter([1.0], [1.0, -phi], rng.standard_normal(n)) * np.sqrt(1.0 - phi**2)


def test_block_length_grows_with_correlation_and_n() -> None:
    rng = np.random.default_rng(0)
    white = [block_length(rng.standard_normal(n)) for n in (600, 3600)]
    assert max(white) <= 3  # no correlation: (nearly) the i.i.d. bootstrap
    strong = [block_length(_ar1(n, 0.9, rng)) for n in (600, 3600, 36_000)]
    # Politis-White's b grows as n^(1/3): about 40, 90, 190 for rho = 0.9
    assert 20 <= strong[0] <= 70 and 50 <= strong[1] <= 150 and 120 <= strong[2] <= 300
    assert strong[0] < strong[1] < strong[2]
    assert block_length(np.ones(100)) == 1  # a constant series
    assert block_length(_ar1(30, 0.99, rng)) <= 10  # capped at n / 3


def test_prefix_sums_equal_resampling_the_epochs() -> None:
    rng = np.random.default_rng(1)
    x = rng.standard_normal(50)
    blocks = Blocks(50, 7, rng.integers(0, 50, size=(5, 8)))
    wrapped = np.concatenate((x, x))  # circular: a block past the end goes on at the start
    direct = [sum(wrapped[s : s + 7].sum() for s in row) for row in blocks.starts]
    assert np.allclose(resampled_sums(blocks, x), direct)
    # steps inside the blocks: 6 per block, the step last -> first left out
    steps = np.diff(x) ** 2
    wrapped_steps = np.concatenate((steps, [0.0], steps))
    direct = [sum(wrapped_steps[s : s + 6].sum() for s in row) for row in blocks.starts]
    assert np.allclose(resampled_sums(blocks, steps, diffs=True), direct)
    assert blocks.size == 56


def test_variance_ratio_restores_the_long_run_variance() -> None:
    rng = np.random.default_rng(2)
    x = _ar1(20_000, 0.9, rng)
    # with b = 10, the bootstrap sees sum (1 - |k|/10) rho^|k|, the truth is (1+rho)/(1-rho)
    truth = 19.0 / (1.0 + 2.0 * sum((1 - k / 10) * 0.9**k for k in range(1, 10)))
    assert variance_ratio(x, 10) == pytest.approx(truth, rel=0.15)
    assert variance_ratio(rng.standard_normal(2000), 10) == pytest.approx(1.0, abs=0.1)


def test_intervals_cover_the_truth_at_the_nominal_rate() -> None:
    # 120 AR(1) error series (rho = 0.8, 400 epochs, the mean 0.02 m, sigma 0.1 m): the
    # 95 % interval of the mean covers 0.02 m, that of the RMSE sqrt(0.02^2 + 0.1^2)
    rng = np.random.default_rng(3)
    reps, n = 120, 400
    cover_mean = cover_rmse = 0
    for k in range(reps):
        e = 0.02 + 0.1 * _ar1(n, 0.8, rng)
        out = distance_intervals(20.0 + e, np.full(n, 20.0), 0.95, (str(k),))
        cover_mean += out["mean_lo"] <= 0.02 <= out["mean_hi"]
        cover_rmse += out["rmse_lo"] <= np.hypot(0.02, 0.1) <= out["rmse_hi"]
    # binomial(120, 0.95): 108 .. 120 holds 99 %; a percentile interval without the
    # corrections covered about 85 %
    assert cover_mean >= 106 and cover_rmse >= 104


def test_intervals_are_seeded_by_names_only() -> None:
    rng = np.random.default_rng(4)
    e = 0.1 * _ar1(500, 0.7, rng)
    ref = 20.0 + np.sin(np.arange(500) / 20.0)
    first = distance_intervals(ref + e, ref, 0.95, ("A-B", "di"))
    assert first == distance_intervals(ref + e, ref, 0.95, ("A-B", "di"))
    assert first != distance_intervals(ref + e, ref, 0.95, ("A-C", "di"))
    # a 90 % interval lies inside the 95 % one
    narrow = distance_intervals(ref + e, ref, 0.9, ("A-B", "di"))
    assert first["rmse_lo"] < narrow["rmse_lo"] < narrow["rmse_hi"] < first["rmse_hi"]
    # too few epochs: no interval
    short = distance_intervals(ref[:10] + e[:10], ref[:10], 0.95, ("A-B", "di"))
    assert all(np.isnan(v) for v in short.values())


def test_quantile_intervals_hold_the_quantile() -> None:
    rng = np.random.default_rng(5)
    hits50 = hits95 = 0
    for k in range(60):
        x = _ar1(600, 0.7, rng)
        h = np.abs(x)  # |N(0, 1)|: median 0.6745, 95th percentile 1.9600
        out = position_intervals(h, x, x, 0.95, (str(k),))
        hits50 += out["cep50_lo"] <= 0.6745 <= out["cep50_hi"]
        hits95 += out["cep95_lo"] <= 1.9600 <= out["cep95_hi"]
    assert hits50 >= 52 and hits95 >= 50  # binomial(60, 0.95): >= 52 in 97 %


def test_paired_difference_of_equal_methods_is_rarely_significant() -> None:
    # two runs of one method on exact ranges with independent noise seeds: 20 seeds,
    # ranges.csv's real time structure (1 Hz, 600 s), AR(1) noise (rho 0.7, the middle of
    # the TIERS residuals' 0.51-0.94). At 5 %, binomial(20, 0.05) exceeds 3 in 1.6 % only.
    t = np.arange(600.0)
    reference = 18.0 + 2.0 * np.sin(2.0 * np.pi * t / 80.0)
    significant = {"rmse": 0, "mean": 0}
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        ranges = pd.DataFrame(
            {
                "time": t,
                "pair": "A-B",
                "observed": reference + 0.1 * _ar1(600, 0.7, rng),
                "again": reference + 0.1 * _ar1(600, 0.7, rng),
                "reference": reference,
            }
        )
        (row,) = distance_comparisons(ranges, ("observed", "again"), 0.95)
        for stat in significant:
            significant[stat] += float(row[f"{stat}_p"]) < 0.05  # type: ignore[arg-type]
    assert significant["rmse"] <= 3 and significant["mean"] <= 3, significant


def test_paired_difference_finds_a_real_improvement() -> None:
    rng = np.random.default_rng(6)
    base = 0.1 * _ar1(900, 0.8, rng)
    better = 0.8 * base + 0.03 * rng.standard_normal(900)  # 20 % smaller, correlated
    out = paired_difference(better, base, 0.95, ("x",))
    assert out["rmse_diff"] < 0 and out["rmse_p"] < 0.01
    assert out["rmse_diff_lo"] < out["rmse_diff"] < out["rmse_diff_hi"] < 0
    # interval and p-value agree: the 95 % interval excludes 0 iff p < 0.05
    same = paired_difference(base, base + 0.0, 0.95, ("x",))
    assert same["rmse_diff"] == 0 and same["rmse_p"] == 1.0


def test_draw_blocks_is_deterministic() -> None:
    a = draw_blocks(100, 9, 10, generator("A-B", "di"))
    b = draw_blocks(100, 9, 10, generator("A-B", "di"))
    assert np.array_equal(a.starts, b.starts) and a.starts.shape == (10, 12)
    assert a.dof == pytest.approx(1.5 * (100 / 9 - 1))
