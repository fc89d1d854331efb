"""An outage in a pair's ranges restarts the distance filter (no event across a gap)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from coopproc.stages.ranging.nlos import filter_distance
from coopproc.stages.ranging.stage import RangingConfig, kernel_params

#: The stage's RN-mode defaults (one-shot estimate, no back-dating), sigma 0.15 m.
PARAMS = kernel_params(RangingConfig(), 0.15, 0.15, 600, rn=True)


def _series_with_outage() -> tuple[np.ndarray, ...]:
    """1 Hz ranges, 30 s outage during which the true distance grows by 9 m; the DI over
    the gap interval says nothing moved (a wrong prediction across the outage)."""
    t = np.concatenate([np.arange(0.0, 60.0), np.arange(90.0, 150.0)])
    truth = np.where(t < 60.0, 20.0, 29.0)
    noise = 0.05 * np.sin(np.arange(t.size) * 1.7)
    di = np.zeros(t.size)
    var = np.full(t.size, 0.02**2)
    return t, truth + noise, di, var, truth


def test_outage_restarts_the_filter_instead_of_flagging_nlos() -> None:
    t, rng_m, di, var, truth = _series_with_outage()
    out = filter_distance(t, rng_m, di, var, PARAMS)
    assert out.nlos_flag.sum() == 0
    after = t >= 90.0
    assert np.max(np.abs(out.distance_m[after] - truth[after])) < 0.2


def test_without_restart_the_jump_would_be_taken_for_nlos() -> None:
    """The same series with restarts off: the 9 m jump is held as an 'NLOS' estimate,
    which is what the restart prevents (shows the test above can fail)."""
    t, rng_m, di, var, _ = _series_with_outage()
    out = filter_distance(t, rng_m, di, var, replace(PARAMS, restart_gap_s=np.inf))
    assert out.nlos_flag.sum() > 10
    assert np.max(out.nlos_estimate_m) > 8.0


def test_event_numbers_run_on_across_pieces() -> None:
    t, rng_m, di, var, _ = _series_with_outage()
    rng_m = rng_m.copy()
    rng_m[(t >= 20) & (t < 30)] += 0.6  # one event before the gap
    rng_m[(t >= 110) & (t < 120)] += 0.6  # one after
    out = filter_distance(t, rng_m, di, var, PARAMS)
    assert sorted(set(out.event[out.event >= 0].tolist())) == [0, 1]
