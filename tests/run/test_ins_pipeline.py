"""The INS in the run chain (coopproc.run.ins, coopproc.stages.ins.ins_stage): which
sessions get the INS modes, the chain, states.csv, the attitude conventions, and the INS
dead reckoning as navigation ([ins] navigation = "ins")."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import ConfigError
from coopproc.io.session import read_session
from coopproc.model import STATES_COLUMNS, Session, Trajectory
from coopproc.run.chain import PipelineParams, resolve
from coopproc.run.config import run_config_from_toml
from coopproc.run.ins import ins_navigation, ins_pipeline, states_table
from coopproc.sim import simulate, write_simulation
from coopproc.stages.base import NavStates, PositionProduct
from coopproc.stages.ins.ins_stage import INS_MODES, InsParams, track_at


@pytest.fixture(scope="module")
def cart(tmp_path_factory: pytest.TempPathFactory) -> Session:
    """A 60-s handcart (6 s static start, tactical IMU at 100 Hz, odometer, 7 anchors)."""
    root = tmp_path_factory.mktemp("ins") / "handcart"
    write_simulation(simulate("handcart", seed=3, duration_s=60), root, force=True)
    return read_session(root)


def test_modes_added_for_imu_sessions_only(cart: Session) -> None:
    params, notes = ins_pipeline(PipelineParams(), cart, InsParams())
    assert params.positions == ("fusion", "lsq", *INS_MODES)
    assert len(notes) == 1 and "cart with an IMU" in notes[0]
    no_imu = dataclasses.replace(cart, imu={})
    assert ins_pipeline(PipelineParams(), no_imu, InsParams()) == (PipelineParams(), [])
    off = InsParams(modes=())
    assert ins_pipeline(PipelineParams(), cart, off)[0] == PipelineParams()
    chosen = PipelineParams(positions=("lsq", "ins_nhc_rts"))
    assert ins_pipeline(chosen, cart, InsParams())[0] == chosen  # the user's list wins
    only_rts = InsParams(modes=("ins_nhc_rts",))
    assert ins_pipeline(PipelineParams(), cart, only_rts)[0].positions == (
        "fusion",
        "lsq",
        "ins_nhc_rts",
    )


def test_ins_modes_run_on_the_observed_ranges_only() -> None:
    steps = resolve(PipelineParams(ranges=("rn", "di"), positions=("lsq", "ins", "ins_rts")))
    methods = [m for s in steps if s.kind == "positions" for m in s.methods]
    assert methods[-5:] == ["lsq", "lsq_rn", "lsq_di", "ins", "ins_rts"]  # no ins_rn, ...


def test_config_checks_modes() -> None:
    cfg = run_config_from_toml({"ins": {"modes": ["ins", "ins_nhc_rts"], "navigation": "ins"}})
    assert cfg.params_for("ins").modes == ("ins", "ins_nhc_rts")
    with pytest.raises(ConfigError, match="ins_rtss"):
        run_config_from_toml({"ins": {"modes": ["ins_rtss"]}})
    with pytest.raises(ConfigError, match="navigation"):
        run_config_from_toml({"ins": {"navigation": "gnss"}})


def test_attitude_conventions() -> None:
    """Engine Euler angles (yaw counter-clockwise from east, pitch positive nose down) to
    states.csv's (heading clockwise from north, pitch nose up), through a wrap of yaw."""
    t_imu = np.array([0.0, 1.0, 2.0])
    track = dataclasses.make_dataclass("T", ["enu_m", "vel_enu", "att_deg", "sigma_enu"])(
        np.zeros((3, 3)),
        np.ones((3, 3)),
        np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 170.0], [1.0, 2.0, -170.0]]),
        np.full((3, 3), 0.1),
    )
    traj, states = track_at("X", np.array([0.0, 1.5, 2.0]), t_imu, track, "test")
    np.testing.assert_allclose(states.att_deg[:, 0], 1.0)
    np.testing.assert_allclose(states.att_deg[:, 1], -2.0)
    # yaw 0 (east) = heading 90; 170 -> -170 passes through 180 (west), not through 0
    np.testing.assert_allclose(states.att_deg[:, 2], [90.0, 270.0, 260.0])
    np.testing.assert_allclose(traj.heading_deg, states.att_deg[:, 2])
    assert np.isnan(states.sigma_vel_mps).all()


def test_states_table_with_reference_heading(cart: Session) -> None:
    t = np.arange(cart.reference["cart"].time_s[0], cart.reference["cart"].time_s[0] + 5, 0.5)
    n = t.size
    s = NavStates(t, np.ones((n, 3)), np.full((n, 3), 10.0), np.zeros((n, 3)), np.zeros((n, 3)))
    product = PositionProduct(positions={}, states={"cart": s})
    assert states_table(cart, {"lsq": PositionProduct(positions={})}) is None
    ref = cart.reference["cart"]
    heading = np.full(len(ref), 45.0)
    with_heading = dataclasses.replace(ref, heading_deg=heading)
    session = dataclasses.replace(cart, reference={"cart": with_heading})
    table = states_table(session, {"ins": product})
    assert table is not None and list(table.columns) == list(STATES_COLUMNS)
    assert list(table["method"].unique()) == ["ins", "reference"]
    refs = table[table["method"] == "reference"]
    assert len(refs) == n
    np.testing.assert_allclose(refs["yaw"], 45.0)
    assert refs["vel_east"].isna().all()  # the reference has no velocity


def _truth(root: Path, platform: str) -> Trajectory:
    frame = pd.read_csv(root / "truth" / f"traj_{platform}.csv")
    return Trajectory(platform, frame["time"].to_numpy(), frame[["east", "north", "up"]].to_numpy())


def test_navigation_from_the_ins(cart: Session) -> None:
    """[ins] navigation = "ins": the cart's nav becomes the INS/NHC/odometer dead
    reckoning at the nav file's epochs, started from the nav file's first epoch; 'given'
    leaves the session as is. Its error: the nav file's start error (0.08 m, truth/
    dr_params.csv) + the odometer scale (0.26 % of 32 m, 0.08 m) + a little heading drift
    (tactical gyros): measured 0.10 m at most, the bound 0.25 m."""
    assert ins_navigation(cart, InsParams()) == (cart, [])
    session, notes = ins_navigation(cart, InsParams(navigation="ins"))
    assert "navigation of cart: the INS dead reckoning" in notes[0]
    nav, given = session.nav["cart"], cart.nav["cart"]
    np.testing.assert_array_equal(nav.time_s, given.time_s)
    assert not np.allclose(nav.enu_m, given.enu_m)
    truth = _truth(cart.root, "cart").interpolate(nav.time_s)
    error = np.hypot(*(nav.enu_m[:, :2] - truth[:, :2]).T)
    assert np.nanmax(error) < 0.25
