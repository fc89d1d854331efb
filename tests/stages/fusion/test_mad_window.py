"""The forward filter's sorted MAD window gives numba's ``np.median`` bit for bit."""

from __future__ import annotations

import numpy as np

from coopproc.estimation.robust import MAD_SCALE, mad_sigma_nb
from coopproc.stages.fusion.mad_window import union_median, window_push


def test_window_median_is_numba_median() -> None:
    rng = np.random.default_rng(3)
    window = 7
    ring = np.zeros(window)
    srt = np.zeros(window + 1)
    state = np.zeros(4, dtype=np.int64)
    # ties and zeros too: rounded values
    values = np.round(np.abs(rng.normal(size=300)), 1)
    for t, value in enumerate(values):
        m = 1 + t % 4
        epoch = np.round(np.abs(rng.normal(size=m)) * 3, 2)
        pooled = np.concatenate([epoch, ring[: min(t, window)]])
        # what the filter took before: numba's np.median of the pooled values
        expected = mad_sigma_nb(pooled, np.ones(pooled.shape[0]), 0.0)
        got = max(MAD_SCALE * union_median(srt, int(state[2]), epoch.copy(), m), 0.0)
        assert got == expected
        window_push(ring, srt, state, value)
        assert np.array_equal(srt[: state[2]], np.sort(ring[: min(t + 1, window)]))
    state = np.zeros(4, dtype=np.int64)  # a NaN is counted, not sorted
    window_push(ring, srt, state, np.nan)
    assert state[3] == 1 and state[2] == 0
    # the even count: the mean of the two middle values as numba computes it
    assert union_median(np.array([0.1, 0.7]), 2, np.array([0.3, 0.2]), 2) == (0.2 + 0.3) / 2
