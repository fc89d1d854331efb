"""Decimation for drawing: spikes and gaps survive, short series are untouched."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from coopproc.report.decimate import decimate, envelope_indices
from coopproc.report.plots import plot_distance_errors


def test_short_series_are_untouched() -> None:
    x = np.arange(100.0)
    y = np.sin(x)
    dx, dy = decimate(x, y, max_points=100)
    assert dx is x or np.array_equal(dx, x)
    assert np.array_equal(dy, y)


def test_a_one_sample_spike_survives() -> None:
    rng = np.random.default_rng(1)
    n = 200_000
    x = np.arange(n, dtype=float)
    y = rng.normal(0.0, 0.1, n)
    y[123_457] = 5.0  # an NLOS jump of one sample
    y[7] = -4.0
    dx, dy = decimate(x, y, max_points=5000)
    assert dy.size <= 5000 + 2  # min and max of 2500 buckets, plus the run's ends
    assert dy.max() == 5.0 and dx[np.argmax(dy)] == 123_457.0
    assert dy.min() == -4.0 and dx[np.argmin(dy)] == 7.0
    assert np.all(np.diff(dx) > 0)  # original order kept


def test_nan_gaps_survive_and_no_bucket_bridges_them() -> None:
    n = 50_000
    x = np.arange(n, dtype=float)
    y = np.cos(x / 500.0)
    gaps = [1000, 1001, 20_000, 33_333]
    y[gaps] = np.nan
    at = envelope_indices(y, max_points=1000)
    kept_nan = at[np.isnan(y[at])]
    assert kept_nan.tolist() == gaps  # every break kept
    # the first and last sample of every run between breaks are kept: lines stop at gaps
    for edge in (0, 999, 1002, 19_999, 20_001, 33_332, 33_334, n - 1):
        assert edge in at
    _, dy = decimate(x, y, max_points=1000)
    assert np.isnan(dy).sum() == len(gaps) and dy.size < 1100


def test_several_series_keep_each_ones_extremes() -> None:
    n = 30_000
    east = np.linspace(0.0, 100.0, n)
    north = np.zeros(n)
    north[10_001] = 3.0
    east[20_002] = -50.0
    at = envelope_indices(east, north, max_points=600)
    assert 10_001 in at and 20_002 in at and at.size < 700


def test_plot_draws_at_most_the_cap_with_the_full_maximum() -> None:
    n = 60_000
    t = 1000.0 + 0.1 * np.arange(n)
    ref = np.full(n, 20.0)
    observed = ref + np.random.default_rng(3).normal(0.0, 0.05, n)
    observed[41_234] = 23.5
    rows = pd.DataFrame({"time": t, "pair": "A-B", "observed": observed, "reference": ref})
    ax = Figure().subplots()
    plot_distance_errors(ax, rows, methods=["observed"])
    (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == "observed"]
    y = np.asarray(line.get_ydata(), float)
    assert y.size <= 5002
    assert np.nanmax(y) == np.max(observed - ref)  # the spike is drawn at full height
