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


def _fast(seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A pair moving metres between its epochs (real MiLUV's quadrotor, 0.8 Hz): ranges,
    the dead reckoning's DI and the cooperative solution's, each with its own noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(240, dtype=float)
    true = 3.0 + 1.2 * np.abs(np.sin(t / 2.0)) + 0.5 * np.sin(t / 7.0)
    dr = np.full(t.shape[0], np.nan)
    cp = np.full(t.shape[0], np.nan)
    dr[1:] = np.diff(true) + rng.normal(0.0, 0.03, t.shape[0] - 1)
    cp[1:] = np.diff(true) + rng.normal(0.0, 0.03, t.shape[0] - 1)
    return true + rng.normal(0.0, 0.08, t.shape[0]), dr, cp


def test_two_witnesses_of_the_motion_find_what_the_ranges_alone_cannot() -> None:
    obs, dr, cp = _fast()
    obs[150] += 1.4  # one range 1.4 m long while the ranges move by up to 1.2 m an epoch
    assert not gross_outliers(obs, dr, OutlierParams())[150]  # the ranges' motion gate
    found = gross_outliers(obs, dr, OutlierParams(), cp)
    assert np.flatnonzero(found).tolist() == [150]
    # the dead reckoning as its own witness (no fusion: the CP DI is the DR DI) adds none
    assert not gross_outliers(obs, dr, OutlierParams(), dr)[150]


def test_a_dead_reckoning_jump_is_not_an_outlier() -> None:
    obs, dr, cp = _fast()
    dr[90] += 1.5  # the DI jumps (a wheel slip), the ranges and the CP DI do not
    dr[91] -= 1.5
    assert not gross_outliers(obs, dr, OutlierParams(), cp).any()
