"""The ranging stage's cooperative solution by ``[fusion] cp_state`` (stages/fusion/entry.py,
shared/dr_corrected.py's corrected_session)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Session, Trajectory
from coopproc.sim import Simulation, simulate
from coopproc.stages.base import PositionInput, PositionProduct
from coopproc.stages.fusion.entry import fusion_stage
from coopproc.stages.fusion.fuse import FusionParams
from coopproc.stages.shared.dr_corrected import corrected_session


def test_cp_state_is_checked() -> None:
    with pytest.raises(ValueError, match="cp_state = 'kalman'"):
        FusionParams(cp_state="kalman")
    with pytest.raises(ValueError, match="needs state = 'dr'"):
        FusionParams(cp_state="corrected", state="position")
    # by default the corrected navigation with DR states, paper 000's own with the
    # position state (docs/methods-ranging.md#cp-state)
    assert FusionParams().cp_mode == "corrected"
    assert FusionParams(state="position").cp_mode == "position"
    assert FusionParams(cp_state="position").cp_mode == "position"


def _turned(traj: Trajectory, rate_deg_per_s: float) -> Trajectory:
    """``traj`` whose east/north steps turn by a heading error growing at ``rate``: a
    follower's gyro bias."""
    t = traj.time_s
    theta = np.radians(rate_deg_per_s * 0.5 * (t[1:] + t[:-1] - 2 * t[0]))
    d = np.diff(traj.enu_m, axis=0)
    enu = traj.enu_m.copy()
    enu[1:, 0] = enu[0, 0] + np.cumsum(np.cos(theta) * d[:, 0] - np.sin(theta) * d[:, 1])
    enu[1:, 1] = enu[0, 1] + np.cumsum(np.sin(theta) * d[:, 0] + np.cos(theta) * d[:, 1])
    return dataclasses.replace(traj, enu_m=enu)


@pytest.fixture(scope="module")
def drifting() -> tuple[Simulation, Session, str]:
    """Four platforms ranging in turn, ten minutes; one follower's dead reckoning turned by
    a heading error of 0.03 deg/s (18 deg at the end)."""
    sim = simulate("large", seed=3, duration_s=600.0, platforms=4)
    session = sim.session
    follower = next(p for p in session.moving_platforms() if session.platforms[p].role != "leader")
    nav = dict(session.nav)
    nav[follower] = _turned(nav[follower], 0.03)
    return sim, dataclasses.replace(session, nav=nav), follower


def test_corrected_session_changes_only_the_followers_with_states(
    drifting: tuple[Simulation, Session, str],
) -> None:
    _, session, follower = drifting
    assert corrected_session(session, None) is session
    t0, t1 = session.nav[follower].time_s[[0, -1]]
    states = pd.DataFrame(
        {"time": [t0, t1], "platform": follower, "heading_error": 0.0, "scale_error": 0.0}
    )
    same = corrected_session(session, states)
    np.testing.assert_allclose(same.nav[follower].enu_m, session.nav[follower].enu_m, atol=1e-9)
    turned = corrected_session(session, states.assign(heading_error=[0.0, 10.0]))
    assert np.abs(turned.nav[follower].enu_m - session.nav[follower].enu_m).max() > 1.0
    for other in session.nav:
        if other != follower:
            assert turned.nav[other] is session.nav[other]
    assert turned.ranges is session.ranges


def _rms_to_truth(sim: Simulation, traj: Trajectory) -> float:
    """RMS east/north error (m) of ``traj`` against the truth at its epochs."""
    truth = sim.truth.trajectories[traj.platform]
    ref = np.stack(
        [np.interp(traj.time_s, truth.time_s, truth.enu_m[:, a]) for a in (0, 1)], axis=1
    )
    return float(np.sqrt(np.mean(np.sum((traj.enu_m[:, :2] - ref) ** 2, axis=1))))


@pytest.fixture(scope="module")
def solutions(drifting: tuple[Simulation, Session, str]) -> dict[str, PositionProduct]:
    """The observed fusion's product with each ``cp_state``."""
    _, session, _ = drifting
    inp = PositionInput(session, "observed", session.ranges.frame, "ranges", want_cp=True)
    return {state: fusion_stage(inp, FusionParams(cp_state=state)) for state in CP_STATES}


CP_STATES = ("position", "corrected", "dr")


def test_the_dr_states_undo_the_turn(
    drifting: tuple[Simulation, Session, str], solutions: dict[str, PositionProduct]
) -> None:
    """The navigation the corrected solution fuses: the turned follower's track corrected by
    the causal filter's heading states is within a few metres of the truth, the turned one
    tens of metres off (18 deg over ten minutes of driving)."""
    sim, session, follower = drifting
    product = solutions["corrected"]
    fixed = corrected_session(session, product.dr_states_forward)
    turned = _rms_to_truth(sim, session.nav[follower])
    assert turned > 10.0
    assert _rms_to_truth(sim, fixed.nav[follower]) < 0.25 * turned


def test_each_cp_state_gives_a_solution_near_the_truth(
    drifting: tuple[Simulation, Session, str], solutions: dict[str, PositionProduct]
) -> None:
    """Every moving platform has a causal and a smoothed CP solution at the range epochs
    in each mode, the follower's within 0.3 m RMS of the truth (its turned navigation is
    tens of metres off); the mode changes the CP solution and nothing the run writes."""
    sim, session, follower = drifting
    base = solutions["position"]
    for state in CP_STATES:
        product = solutions[state]
        assert product.cp is not None
        forward, smoothed = product.cp
        assert set(forward) == set(smoothed) == set(session.moving_platforms())
        assert _rms_to_truth(sim, forward[follower]) < 0.3, state
        for p, traj in product.positions.items():
            np.testing.assert_array_equal(traj.enu_m, base.positions[p].enu_m)
    cp_a, cp_b = (solutions[state].cp for state in ("position", "corrected"))
    assert cp_a is not None and cp_b is not None
    a, b = cp_a[0][follower].enu_m, cp_b[0][follower].enu_m
    assert a.shape == b.shape and np.abs(a - b).max() > 0.01
