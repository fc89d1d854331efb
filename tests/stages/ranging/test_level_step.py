"""The level series' step test that one range cannot make (stages/ranging/jump.py
``level_step``), and the two-run combination's extensions that it and the level's lift
back (stages/ranging/onerun.py ``trusted_edges``): a hold that one long range started is
not extended over line of sight; an event the forward run ended early is."""

from __future__ import annotations

import dataclasses

import numpy as np

from coopproc.stages.ranging.jump import level_step, range_jump
from coopproc.stages.ranging.nlos import DistanceFilterOutput, KernelParams
from coopproc.stages.ranging.onerun import trusted_edges

N = 160
T = np.arange(N) * 1.25  # 0.8 Hz, like real MiLUV's ranges to one anchor


def _level(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, 0.05, N)


def test_one_long_range_makes_no_step() -> None:
    level = _level()
    k = 100
    level[k - 1] += 1.4  # one range 1.4 m long just before the tested epoch
    plain, _ = range_jump(T, level, k, 5.0)
    robust, _ = level_step(T, level, k, 5.0)
    assert plain < -0.1  # the plain fit reads the one range as the level stepping down
    assert abs(robust) < 0.06


def test_a_real_step_is_measured_as_before() -> None:
    level = _level(1)
    level[100:] += 0.5
    robust, var = level_step(T, level, 100, 5.0)
    plain, plain_var = range_jump(T, level, 100, 5.0)
    assert abs(robust - 0.5) < 0.08
    assert robust == plain and var == plain_var  # no value left out: the same fit


def _run(flag: np.ndarray, est: float) -> DistanceFilterOutput:
    n = flag.shape[0]
    event = np.where(flag, 0, -1).astype(np.int64)
    return DistanceFilterOutput(
        distance_m=np.zeros(n),
        nlos_flag=flag.astype(np.int8),
        nlos_estimate_m=np.where(flag, est, 0.0),
        event=event,
        step_estimate_m=np.full(n, np.nan),
        sigma_m=np.full(n, 0.13),
        residual_m=np.zeros(n),
    )


PARAMS = KernelParams(
    sigma_m=0.13, initial_sigma_m=0.13, gamma_sigma=3.0, window_s=3.0, aligned=True,
    di_accel_sigma=0.0, one_shot=False, backdate_s=2.0, onset_fraction=0.5,
    confirm_fraction=0.5, end_confirm_s=1.0, end_min_epochs=2, adaptive_n=30,
    adaptive_min_n=10, min_sigma_m=0.01, suspect_epochs=3, positive_only=True,
    max_event_s=120.0, jump_fraction=0.5, jump_window_s=5.0,
)  # fmt: skip


def _edges(level: np.ndarray, fwd_hi: int, bwd: tuple[int, int]) -> np.ndarray:
    """The backward-only epochs added: a forward event [60, fwd_hi), a backward event
    [bwd[0], bwd[1]) (its detection at bwd[1] - 1), both flagged where they overlap."""
    fwd_flag = np.zeros(N, dtype=bool)
    fwd_flag[60:fwd_hi] = True
    bwd_flag = np.zeros(N, dtype=bool)
    bwd_flag[bwd[0] : bwd[1]] = True
    fwd = _run(fwd_flag, 0.5)
    rev = _run(bwd_flag[::-1], 0.5)
    both = fwd_flag & bwd_flag
    _, bwd_only = trusted_edges(T, level, both, fwd, rev, dataclasses.replace(PARAMS))
    return bwd_only


def test_a_hold_one_long_range_started_is_not_extended() -> None:
    # a real 3-epoch event of 0.3 m at 60-62, line of sight after it; the backward run
    # detected a range 1.4 m long at 99 and held 0.5 m back to 60 (real MiLUV: a 46 s
    # hold). The plain fit read the long range as a level step down of 0.48 m at 100,
    # more than the 0.29 m where the forward run's event ended: 37 epochs were added.
    level = _level(2)
    level[60:63] += 0.3
    level[99] += 1.4
    assert not _edges(level, 63, (60, 100)).any()


def test_an_event_the_forward_run_ended_early_is_extended() -> None:
    # a real 40-epoch event at 60-99 (the ranges 0.5 m long); the forward run ended it at
    # 63, the backward run held it from its detection at 99
    level = _level(3)
    level[60:100] += 0.5
    added = _edges(level, 63, (60, 100))
    assert added[63:100].all() and not added[:63].any() and not added[100:].any()
