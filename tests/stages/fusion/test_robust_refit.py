"""The smoothed solution's robust factors: a platform that is off is not its ranges' fault.

:func:`smoothed_gammas` on a synthetic four-platform solution: every epoch holds the six
ranges; the smoothed positions are the truth except where a test moves them.
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.robust import GAMMA_REJECT
from coopproc.stages.fusion.ekf import OBS_RANGE
from coopproc.stages.fusion.robust_refit import smoothed_gammas

TRUTH = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [-7.0, -7.0]])
PAIRS = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
N_EP = 60
SIGMA = 0.1


def _case(shift: np.ndarray | None, excess: dict[tuple[int, int], float], timed: bool = True):
    """Factors, residuals, standardized values, the window mask and each range's first end
    (``timed = False``: without the epoch times, so without the platform rule)."""
    rng = np.random.default_rng(4)
    n_obs = N_EP * len(PAIRS)
    a = np.tile([p[0] for p in PAIRS], N_EP)
    b = np.tile([p[1] for p in PAIRS], N_EP)
    z = np.linalg.norm(TRUTH[a] - TRUTH[b], axis=1) + rng.normal(0.0, SIGMA, n_obs)
    epoch = np.repeat(np.arange(N_EP), len(PAIRS))
    time_s = np.arange(N_EP, dtype=float)
    window = (epoch >= 20) & (epoch < 35)
    for pair, size in excess.items():  # NLOS: these ranges read long in the window
        z[window & (a == pair[0]) & (b == pair[1])] += size
    obs = {
        "kind": np.full(n_obs, OBS_RANGE, dtype=np.int8),
        "a": a.astype(np.int32),
        "b": b.astype(np.int32),
        "anchor": np.zeros(n_obs, dtype=np.int32),
        "anchor_table": np.zeros((1, 3)),
        "dz2": np.zeros(n_obs),
        "z": z,
        "var": np.full(n_obs, SIGMA**2),
        "ptr": np.arange(0, n_obs + 1, len(PAIRS), dtype=np.int64),
    }
    xs = np.tile(TRUTH, (N_EP, 1))  # slot (epoch, platform)
    if shift is not None:  # platform 0's smoothed positions off by ``shift`` in the window
        xs[np.arange(20, 35) * 4] += shift
    rec_ptr = np.arange(0, 4 * N_EP + 1, 4, dtype=np.int64)
    rec_plat = np.tile(np.arange(4, dtype=np.int64), N_EP)
    gamma, resid, std = smoothed_gammas(
        obs, rec_ptr, rec_plat, xs, 4, 2, np.ones(n_obs), 3.0, 4.5, 1.0, time_s if timed else None
    )
    return gamma, resid, std, window, a


def test_a_platform_off_has_its_ranges_readmitted() -> None:
    shift = np.array([0.9, 0.6])
    gamma, resid, std, window, a = _case(shift, {})
    assert np.nanmax(np.abs(std)) < 3.0  # every decision now within k0
    # without the rule the shift rejects 0-1 (0.9 m, 9 sigma) and 0-3 (1.06 m)
    plain, *_ = _case(shift, {}, timed=False)
    assert (plain[window & (a == 0)] == GAMMA_REJECT).sum() >= 20
    assert np.all(gamma == 1.0)
    # the reported residual is the one with platform 0 shifted back: noise-sized
    assert np.nanmax(np.abs(resid[window & (a == 0)])) < 0.4


def test_nlos_on_two_pairs_stays_rejected() -> None:
    gamma, _, _, window, a = _case(None, {(0, 1): 0.8, (0, 2): 0.8})
    b = np.tile([p[1] for p in PAIRS], N_EP)
    nlos = window & (a == 0) & np.isin(b, [1, 2])
    assert np.all(gamma[nlos] == GAMMA_REJECT)
    assert np.all(gamma[~window] == 1.0)
