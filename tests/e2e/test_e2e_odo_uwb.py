"""The odometer/UWB filter through files: the real TUC session and a simulated one.

Real (../shared/data/real/tuc, skipped when absent): a differential-drive robot with wheel
speeds, ranging to four modules in a 2.4 m square. ``coopproc run`` adds ``odo_uwb`` and
``odo_uwb_rts``; both must beat the robot's own dead reckoning (1.92 m RMSE) and UWB-only
positioning (``lsq_rts``: 0.175 m with the robot run as a tag, the number issue 12 gives;
the same run's ``lsq_rts`` as a follower is worse). Cross-checks: with one module left out
the smoother still beats ``lsq_rts`` with all four; with UWB withheld for 10 s the
filter, coasting on the calibrated odometer, ends far closer than the raw dead reckoning
drifts over the same 10 s.

Simulated (``anchors``, 120 s, ``--imu 50``: odometer speed + IMU, so the yaw rate comes
from the z gyro): true range noise SIGMA_R = 0.08 m (SimParams.uwb_noise_m), HDOP about
0.84. One round of ranges to the six anchors fixes the tag to about SIGMA_R * HDOP; the
odometer and gyro drift over a round (about 1.3 s) by millimetres, so the smoother
averages several rounds: its RMSE must be below 0.5 SIGMA_R and the causal filter's below
0.75 SIGMA_R (measured 0.34 and 0.53 SIGMA_R), and both must beat the DR and lsq_rts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.session import read_session
from coopproc.model import Session, Trajectory
from coopproc.run.chain import PipelineParams
from coopproc.run.odo_methods import odo_pipeline
from coopproc.stages.anchors.anchor_lsq import anchor_fixes
from coopproc.stages.anchors.uwb_kf import uwb_kf_positions
from coopproc.stages.odometry.odo_track import OdoUwbParams, odo_tracks
from coopproc.stages.odometry.odo_uwb import fit_track, odo_uwb_positions
from coopproc.stages.shared.lsq import LsqParams

REAL_TUC = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real" / "tuc"
#: lsq_rts on real/tuc with the robot as a tag (issue 12's figure)
TUC_LSQ_RTS_M = 0.175
#: the simulator's true UWB white noise (SimParams.uwb_noise_m)
SIGMA_R = 0.08


def _rmse_at(session: Session, traj: Trajectory, times: np.ndarray) -> float:
    pos = np.column_stack([np.interp(times, traj.time_s, traj.enu_m[:, i]) for i in (0, 1)])
    truth = session.reference[traj.platform].interpolate_within(times)[:, :2]
    return float(np.sqrt(np.nanmean(np.sum((pos - truth) ** 2, axis=1))))


def _ranges(session: Session) -> pd.DataFrame:
    return session.ranges.frame[["time", "from", "to", "range", "sigma"]]


@pytest.fixture(scope="module")
def tuc() -> Path:
    if not REAL_TUC.is_dir():
        pytest.skip("shared/data/real is not present")
    return REAL_TUC


def test_real_tuc_odometer_uwb_beats_dead_reckoning_and_uwb_only(tuc: Path, tmp_path: Path) -> None:
    cfg = tmp_path / "run.toml"
    cfg.write_text(
        '[pipeline]\nranges = []\npositions = ["lsq_rts"]\n[fusion.lsq]\nepoch_merge_s = 0.5\n'
    )
    out = tmp_path / "out"
    res = CliRunner().invoke(
        main, ["run", str(tuc), "-o", str(out), "--no-figures", "--config", str(cfg)]
    )
    assert res.exit_code == 0, res.output
    assert "odo_uwb, odo_uwb_rts added" in res.output
    assert "the wheel speeds turn opposite to the UWB track" in res.output
    m = pd.read_csv(out / "position_metrics.csv").set_index(["platform", "method"])["rmse"]
    nav, lsq = m["robot", "nav"], m["robot", "lsq_rts"]
    filtered, smoothed = m["robot", "odo_uwb"], m["robot", "odo_uwb_rts"]
    assert nav > 1.5  # the wheel odometry alone (1.92 m)
    for value in (filtered, smoothed):
        assert value < min(lsq, TUC_LSQ_RTS_M) / 1.5  # measured 0.073 and 0.046 m
    assert smoothed < 0.75 * filtered
    positions = pd.read_csv(out / "positions.csv")
    assert {"odo_uwb", "odo_uwb_rts"} <= set(positions["method"])


def test_real_tuc_cross_checks_leave_one_module_out_and_withhold_uwb(tuc: Path) -> None:
    session = read_session(tuc)
    ranges = _ranges(session)
    own = np.unique(ranges["time"].to_numpy())
    for module in ("u105", "u108"):  # the least and the most useful module
        kept = ranges[(ranges["from"] != module) & (ranges["to"] != module)]
        traj, _ = odo_uwb_positions(session, kept, OdoUwbParams(), smooth=True)
        assert _rmse_at(session, traj["robot"], own) < TUC_LSQ_RTS_M  # measured 0.041, 0.093
    # UWB withheld over [12, 22] s: the filter coasts on the calibrated odometer
    start, end = 12.0, 22.0
    kept = ranges[(ranges["time"] <= start) | (ranges["time"] >= end)]
    tracks, _ = odo_tracks(session, kept, OdoUwbParams())
    track = tracks["robot"]
    fit = fit_track(track, OdoUwbParams())
    at = int(np.searchsorted(track.t, end)) - 1  # the last step before UWB returns
    truth = session.reference["robot"].interpolate_within(np.array([start, track.t[at]]))[:, :2]
    coast = float(np.hypot(*(fit.xf[at, :2] - truth[1])))
    nav = session.nav["robot"].interpolate(np.array([start, track.t[at]]))[:, :2]
    drift = float(np.hypot(*((nav[1] - nav[0]) - (truth[1] - truth[0]))))
    assert coast < 0.25 * drift, (coast, drift)  # measured 0.13 m against 2.1 m


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Session:
    path = tmp_path_factory.mktemp("odo") / "anchors"
    args = ["simulate", str(path), "--scenario", "anchors", "--seed", "3"]
    res = CliRunner().invoke(main, [*args, "--duration", "120", "--imu", "50"])
    assert res.exit_code == 0, res.output
    return read_session(path)


def test_simulated_odometer_and_gyro_meet_the_noise_targets(simulated: Session) -> None:
    ranges = _ranges(simulated)
    assert simulated.odometer["tag"].yaw_rate_radps is None  # speed only: the gyro's yaw
    own = np.unique(ranges["time"].to_numpy())
    filtered, notes = odo_uwb_positions(simulated, ranges, OdoUwbParams(), smooth=False)
    smoothed, _ = odo_uwb_positions(simulated, ranges, OdoUwbParams(), smooth=True)
    assert "yaw rate from the IMU z gyro" in notes[0]
    f_rmse = _rmse_at(simulated, filtered["tag"], own)
    s_rmse = _rmse_at(simulated, smoothed["tag"], own)
    assert s_rmse < 0.5 * SIGMA_R, s_rmse
    assert f_rmse < 0.75 * SIGMA_R, f_rmse
    fixes = anchor_fixes(simulated, ranges, LsqParams()).fixes
    lsq = uwb_kf_positions(fixes, LsqParams(), smooth=True)["tag"]
    lsq_rmse = _rmse_at(simulated, lsq, lsq.time_s)
    nav = simulated.nav["tag"]
    nav_rmse = _rmse_at(simulated, nav, nav.time_s)
    assert f_rmse < min(lsq_rmse, nav_rmse), (f_rmse, lsq_rmse, nav_rmse)


def test_the_methods_are_added_only_for_platforms_with_an_odometer(simulated: Session) -> None:
    params = PipelineParams(positions=("fusion",))
    chain, notes = odo_pipeline(params, simulated, OdoUwbParams())
    assert chain.positions == ("fusion", "odo_uwb", "odo_uwb_rts") and len(notes) == 1
    assert odo_pipeline(params, simulated, OdoUwbParams(auto=False)) == (params, [])
    named = PipelineParams(positions=("odo_uwb_rts",))
    assert odo_pipeline(named, simulated, OdoUwbParams()) == (named, [])
    # a session without odometer files: the very same chain (its outputs stay byte-identical)
    plain = read_session(Path(__file__).resolve().parents[2] / "sample_logs")
    assert not plain.odometer
    assert odo_pipeline(params, plain, OdoUwbParams())[0] is params
