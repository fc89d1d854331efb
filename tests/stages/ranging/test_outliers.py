"""Gross range outliers (coopproc.stages.ranging.outliers): found, and only they."""

from __future__ import annotations

import numpy as np

from coopproc.stages.ranging.outliers import OutlierParams, gross_outliers


def _series(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    true = 20.0 + 5.0 * np.sin(t / 40.0)  # a moving pair
    di = np.full(n, np.nan)
    di[1:] = np.diff(true) + rng.normal(0.0, 0.005, n - 1)
    return true + rng.normal(0.0, 0.08, n), di


def test_spikes_of_any_size_are_outliers_and_nothing_else() -> None:
    obs, di = _series()
    for k, size in ((50, 5.0), (120, 20.0), (300, 1980.0), (360, -1.5)):
        obs[k] += size
    found = gross_outliers(obs, di, OutlierParams())
    assert np.flatnonzero(found).tolist() == [50, 120, 300, 360]


def test_fast_motion_is_not_an_outlier() -> None:
    t = np.arange(200, dtype=float)
    obs = 30.0 + 8.0 * np.abs(np.sin(t / 3.0))  # 8 m swings in a few epochs
    assert not gross_outliers(obs, None, OutlierParams()).any()


def test_nlos_steps_and_long_excursions_are_left_to_the_nlos_filter() -> None:
    obs, di = _series()
    obs[100:110] += 0.5  # a 10-epoch NLOS event
    obs[200:203] += 3.0  # three epochs: longer than max_run
    obs[250] += 0.3  # 3.75 sigma: within the gate
    assert not gross_outliers(obs, di, OutlierParams()).any()


def test_without_dead_reckoning_the_range_itself_is_tested() -> None:
    obs, _ = _series()
    obs[77] -= 4.0
    found = gross_outliers(obs, None, OutlierParams())
    assert np.flatnonzero(found).tolist() == [77]
    assert not gross_outliers(obs, None, OutlierParams(enabled=False)).any()
