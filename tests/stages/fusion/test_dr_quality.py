"""The dead-reckoning quality's Theil-Sen slope: scipy's, bit for bit, without n x n arrays."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import theilslopes

from coopproc.stages.fusion.dr_quality import _sampled_median, theil_sen_slope


@pytest.mark.parametrize("n", [2, 12, 13, 200])
@pytest.mark.parametrize("ties", [False, True])
def test_theil_sen_slope_is_scipys_bit_for_bit(n: int, ties: bool) -> None:
    rng = np.random.default_rng(n + 7 * ties)
    x = rng.uniform(0.0, 30.0, n)
    if ties:  # repeated x (pairs with equal x have no slope), unsorted
        x = np.round(x / 3.0) * 3.0
        x[-1] = x[0] + 1.0
    y = 0.4 * x + rng.standard_cauchy(n)
    assert theil_sen_slope(y, x) == theilslopes(y, x)[0]


@pytest.mark.parametrize("seed", [0, 1])
def test_theil_sen_slope_of_a_long_increasing_series_is_scipys_bit_for_bit(seed: int) -> None:
    # at 600+ points (increasing, finite) the median is bracketed from a sample and
    # taken among the slopes inside the bracket: still exactly scipy's
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.1, 1.0, 1201 + seed))  # an even and an odd slope count
    y = 0.4 * x + rng.standard_cauchy(x.shape[0])
    if seed:
        y = np.round(y, 1)  # many equal slopes around the median
    expected = theilslopes(y, x)[0]
    assert _sampled_median(y, x) == expected  # the bracket held (no fallback)
    assert theil_sen_slope(y, x) == expected


def test_theil_sen_slope_resists_outliers_and_passes_nan() -> None:
    x = np.arange(40.0)
    y = 2.0 * x
    y[[3, 17, 30]] += [500.0, -800.0, 90.0]  # gross errors do not tilt the median slope
    assert theil_sen_slope(y, x) == pytest.approx(2.0, abs=1e-12)
    y[5] = np.nan  # NaN slopes make the median NaN, as in scipy
    assert np.isnan(theil_sen_slope(y, x)) and np.isnan(theilslopes(y, x)[0])
