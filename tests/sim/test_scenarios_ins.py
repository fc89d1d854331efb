"""The INS scenarios (issue 12 item 6): handcart (paper 003) and land-vehicle (odometer,
NHC) with a static start, IMU and odometer files, and what coopproc run makes of them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from coopproc.checks.coverage import prepare_run
from coopproc.io import read_session
from coopproc.report.metrics import position_metrics
from coopproc.run.chain import PipelineParams
from coopproc.run.config import RunConfig, RunParams
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate, write_simulation
from coopproc.sim.imu import imu_truth, to_body
from coopproc.sim.ins_worlds import CART_SITES, POLE_SITES


@pytest.mark.parametrize(
    ("scenario", "pid", "speed", "static_s", "grade", "anchors"),
    [
        ("handcart", "cart", 0.6, 6.0, "tactical", 7),
        ("land-vehicle", "car", 8.0, 6.0, "industrial", 6),
    ],
)
def test_static_start_then_the_route_with_imu_and_odometer(
    scenario: str, pid: str, speed: float, static_s: float, grade: str, anchors: int
) -> None:
    sim = simulate(scenario, seed=2, duration_s=60.0)
    truth = sim.truth.trajectories[pid]
    t = truth.time_s - truth.time_s[0]
    still = truth.enu_m[t <= static_s]
    assert np.ptp(still, axis=0).max() == 0.0  # a tenth of the 60 s session
    assert not np.allclose(truth.enu_m[t > static_s + 0.5][0], still[0])
    step = np.diff(truth.enu_m[:, :2], axis=0)
    cruise = np.hypot(step[:, 0], step[:, 1])[t[1:] > static_s + 5.0] / np.diff(t)[0]
    assert np.mean(cruise) == pytest.approx(speed, rel=0.06)
    sites = CART_SITES if scenario == "handcart" else POLE_SITES
    fixed = [p for p in sim.session.platforms.values() if p.role == "anchor"]
    assert len(fixed) == anchors == len(sim.session.ranges.pairs)
    assert {tuple(np.round(sim.truth.trajectories[p.id].enu_m[0], 6)) for p in fixed} == set(
        sites[:anchors]
    )
    imu, odo = sim.session.imu[pid], sim.session.odometer[pid]
    assert np.median(np.diff(imu.time_s)) == pytest.approx(0.01)  # 100 Hz by default
    assert sim.truth.imu_errors["grade"].tolist() == [grade]
    declared = sim.session.platforms[pid]  # session.toml says what was drawn
    assert declared.imu is not None and declared.imu.grade == grade and declared.nhc is True
    assert all(p.imu is None for p in sim.session.platforms.values() if p.role == "anchor")
    # at rest the accelerometers read gravity only (9.797 m/s^2 here, plus turn-on biases
    # of a few mg) and the odometer zero (to 0.1 mm/s: the spline starts moving early)
    rest = imu.time_s - imu.time_s[0] < static_s - 0.5
    assert np.linalg.norm(imu.accel_mps2[rest].mean(axis=0)) == pytest.approx(9.797, abs=0.05)
    assert np.abs(odo.speed_mps[odo.time_s - odo.time_s[0] < static_s - 0.5]).max() < 1e-4
    # non-holonomic: the body velocity has no lateral or vertical part, the odometer
    # measures the whole speed
    ideal = imu_truth(truth, odo.time_s, sim.session.origin_llh, earth=True)
    body = to_body(ideal.vel_enu_mps, ideal.yaw_rad, ideal.pitch_rad)
    assert np.abs(body[:, 1:]).max() < 1e-5  # (held attitude below 2 cm/s)
    scale = float(sim.truth.imu_errors["odo_scale"].iloc[0])
    moving = body[:, 0] > 1.0 if pid == "car" else body[:, 0] > 0.3
    assert np.median(odo.speed_mps[moving] / body[moving, 0]) == pytest.approx(1 + scale, abs=2e-3)


@pytest.mark.parametrize("scenario", ["handcart", "land-vehicle"])
def test_the_scenarios_simulate_write_and_run(scenario: str, tmp_path: Path) -> None:
    written = tmp_path / scenario
    write_simulation(simulate(scenario, seed=1, duration_s=60.0), written)
    back = read_session(written)
    pid = "cart" if scenario == "handcart" else "car"
    assert set(back.imu) == {pid} and set(back.odometer) == {pid}
    assert (written / f"imu_{pid}.csv").is_file() and (
        written / "truth" / "imu_errors.csv"
    ).is_file()
    # the dead-reckoning methods of the chain (the INS ones are tests/ins): fusion with
    # the anchors beats the platform's own navigation
    plain = tmp_path / f"{scenario}-dr"
    write_simulation(simulate(scenario, seed=1, duration_s=60.0, imu_rate_hz=0.0), plain)
    session = prepare_run(read_session(plain))[0]
    config = RunConfig(
        run=RunParams(figures=False), pipeline=PipelineParams(ranges=(), positions=("fusion",))
    )
    table = position_metrics(run_pipeline(session, config).result.positions)
    rmse = dict(zip(table["method"], table["rmse"], strict=False))
    # (seed 1: handcart 0.020 m against 0.094 m, land-vehicle 0.044 m against 0.46 m; the
    # ranging noise 0.08 m over 6-7 anchors, HDOP about 1)
    assert rmse["observed"] < 0.08 and rmse["observed"] < 0.5 * rmse["nav"]
