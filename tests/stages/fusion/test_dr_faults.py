"""A platform whose dead reckoning jumps (dr_faults.py): found by the forward filter,
given as process noise, and nothing found where nothing jumped.

The simulated ``dr-faults`` scenario (600 s, leader B and three followers that each range
the other three; odometer over-reads of 20-50 % for 2-6 s, 10-20 a session) against its
truth; the same scenario without slips, and ``large`` (10 platforms, NLOS events) for
false alarms.
"""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.sim import simulate
from coopproc.sim.truth import Simulation
from coopproc.stages.fusion.dr_faults import (
    JUMP_COLUMNS,
    SPREAD_WINDOWS,
    confirmed_jumps,
    spread_jumps,
)
from coopproc.stages.fusion.fuse import FusionOutput, FusionParams, fuse
from coopproc.stages.fusion.kernel_types import Navigation, Process, Slots


def _fused(sim: Simulation, **params: float) -> FusionOutput:
    frame = sim.session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    return fuse(sim.session, frame, FusionParams(**params))


def _mean_errors(sim: Simulation, out: FusionOutput) -> dict[str, float]:
    errors = {}
    for pid, traj in out.smoothed.items():
        truth = sim.truth.trajectories[pid]
        de = np.interp(traj.time_s, truth.time_s, truth.enu_m[:, 0]) - traj.enu_m[:, 0]
        dn = np.interp(traj.time_s, truth.time_s, truth.enu_m[:, 1]) - traj.enu_m[:, 1]
        errors[pid] = float(np.hypot(de, dn).mean())
    return errors


@pytest.fixture(scope="module")
def slips() -> Simulation:
    return simulate("dr-faults", seed=0)


def test_the_slips_are_found_where_they_happened(slips: Simulation) -> None:
    out = _fused(slips)
    jumps = out.dr_jumps
    assert jumps is not None and list(jumps.columns) == list(JUMP_COLUMNS)
    faults = slips.truth.nav_faults
    truth = faults[faults["fault"] == "slip"]
    window = FusionParams().dr_fault_window_s
    # every jump follows a slip of that platform: found from its start to two windows
    # after its end (the evidence of a slip is complete near its end)
    for row in jumps.itertuples():
        own = truth[truth["platform"] == row.platform]
        assert ((own["start"] <= row.time) & (row.time <= own["end"] + 2 * window)).any(), row
    found = sum(
        bool(
            (
                (jumps["platform"] == s.platform)
                & (jumps["time"] >= s.start)
                & (jumps["time"] <= s.end + 2 * window)
            ).any()
        )
        for s in truth.itertuples()
    )
    assert found >= 10 and len(truth) == 14  # measured: 11 of the 14 slips
    # a 20-50 % over-read at 0.5 m/s for 2-6 s: 0.2-1.5 m
    assert jumps["size_m"].between(0.15, 1.5).all()


def test_the_jumps_halve_the_followers_error(slips: Simulation) -> None:
    with_jumps = _mean_errors(slips, _fused(slips))
    without = _mean_errors(slips, _fused(slips, dr_fault_window_s=0.0))
    # measured: A / C / D 0.061 / 0.084 / 0.072 m against 0.145 / 0.164 / 0.180 m
    for pid in ("A", "C", "D"):
        assert with_jumps[pid] < 0.6 * without[pid], (pid, with_jumps, without)
        assert with_jumps[pid] < 0.095
    assert with_jumps["B"] == pytest.approx(without["B"], abs=1e-4)  # the leader: its fixes


@pytest.mark.parametrize(
    "scenario, overrides",
    [("dr-faults", {"slip_rate_per_hour": 0.0}), ("large", {"duration_s": 600.0})],
)
def test_nothing_is_found_where_nothing_jumped(scenario: str, overrides: dict) -> None:
    # the same heading fault and NLOS events without slips; ten platforms with NLOS
    sim = simulate(scenario, seed=0, **overrides)
    out = _fused(sim)
    assert out.dr_jumps is not None and out.dr_jumps.empty
    off = _fused(sim, dr_fault_window_s=0.0)
    for pid, traj in out.smoothed.items():
        assert np.array_equal(traj.enu_m, off.smoothed[pid].enu_m)


def test_the_position_state_has_no_jumps(slips: Simulation) -> None:
    # paper 000's own fusion stays as the paper writes it
    out = _fused(slips, state="position")
    plain = _fused(slips, state="position", dr_fault_window_s=0.0)
    assert out.dr_jumps is not None and out.dr_jumps.empty
    for pid, traj in out.smoothed.items():
        assert np.array_equal(traj.enu_m, plain.smoothed[pid].enu_m)


def test_a_jump_is_spread_over_the_windows_before_it() -> None:
    epochs = np.arange(0.0, 30.0, 0.5)
    none = np.zeros(0, np.int64)
    proc = Process.of(np.zeros(2), False, np.full(60, 0.5), np.full(2, -1), np.zeros((2, 5)))
    proc = proc._replace(
        jump_k=np.array([40], np.int64), jump_p=np.array([1], np.int64),
        jump_var=np.array([0.36]),
    )  # fmt: skip
    spread = spread_jumps(proc, epochs, 2.0)
    # 20 s, back SPREAD_WINDOWS x 2 s = 4 s: epochs 16.0 .. 20.0
    assert SPREAD_WINDOWS == 2.0
    assert epochs[spread.jump_k].tolist() == pytest.approx(np.arange(16.0, 20.01, 0.5).tolist())
    assert np.all(spread.jump_p == 1)
    assert spread.jump_var.sum() == pytest.approx(0.36)
    assert spread_jumps(proc._replace(jump_k=none, jump_p=none, jump_var=np.zeros(0)),
                        epochs, 2.0).jump_k.shape == (0,)  # fmt: skip


def test_the_refit_keeps_the_jumps_the_smoothed_solution_steps_at() -> None:
    # two platforms recorded at every epoch (1 s apart), navigation standing still; the
    # smoothed solution of platform 0 steps by 0.5 m at epoch 10, platform 1's by 0.1 m
    n_ep = 20
    epochs = np.arange(float(n_ep))
    nav = Navigation(
        epochs, np.tile(epochs, 2), np.zeros((2 * n_ep, 2)), np.array([0, n_ep, 2 * n_ep])
    )
    slots = Slots(np.arange(0, 2 * n_ep + 1, 2, dtype=np.int64), np.tile(np.arange(2), n_ep))
    xs = np.zeros((2 * n_ep, 2))
    xs[2 * 10 :: 2, 0] = 0.5  # platform 0 from epoch 10 on
    xs[2 * 10 + 1 :: 2, 1] = 0.1
    proc = Process.of(np.zeros(2), False, np.ones(n_ep), np.full(2, -1), np.zeros((2, 5)))
    proc = proc._replace(
        jump_k=np.array([10, 10], np.int64), jump_p=np.array([0, 1], np.int64),
        jump_var=np.array([0.4**2, 1.0**2]),
    )  # fmt: skip
    kept = confirmed_jumps(proc, epochs, nav, slots, xs)
    assert kept.jump_p.tolist() == [0] and kept.jump_k.tolist() == [10]
    assert kept.jump_var[0] == pytest.approx(0.25)  # the smoothed step's, not the forward's
