"""The simulator's physics against what it was configured with (in memory, no files)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.errors import ConfigError
from coopproc.sim import SCENARIOS, simulate
from coopproc.sim.deadreckoning import DrErrors, dead_reckon
from coopproc.sim.formation import distance_rate_rms
from tests.sim.quiet import quiet_params

_DPH = np.pi / 180.0 / 3600.0


def _straight(duration_s: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, duration_s + 1e-9, 0.1)
    enu = np.column_stack((np.zeros_like(t), speed * t, np.zeros_like(t)))  # due north
    return t, enu


def test_dr_scale_factor_error_is_scale_times_distance() -> None:
    t, enu = _straight(600.0, 0.5)
    errors = DrErrors(
        gyro_bias_dph=0.0, odo_scale=0.004, heading_init_deg=0.0, init_error_m=(0, 0, 0)
    )
    dr, heading, _ = dead_reckon(enu, t, quiet_params(), errors, np.random.default_rng(0))
    along = dr[:, 1] - enu[:, 1]
    assert along[-1] == pytest.approx(0.004 * 300.0, rel=1e-9)
    assert np.allclose(dr[:, 0], 0.0)
    assert np.allclose(heading, 0.0)


def test_dr_gyro_bias_gives_quadratic_cross_track_error() -> None:
    # heading error b t on a straight run: cross-track error ~ v b t^2 / 2
    t, enu = _straight(600.0, 0.5)
    errors = DrErrors(
        gyro_bias_dph=2.7, odo_scale=0.0, heading_init_deg=0.0, init_error_m=(0, 0, 0)
    )
    dr, heading, _ = dead_reckon(enu, t, quiet_params(), errors, np.random.default_rng(0))
    expected = 0.5 * 2.7 * _DPH * 600.0**2 / 2.0
    assert dr[-1, 0] == pytest.approx(expected, rel=0.01)
    half = np.searchsorted(t, 300.0)
    assert dr[half, 0] == pytest.approx(expected / 4.0, rel=0.02)  # grows as t^2
    assert heading[-2] == pytest.approx(2.7 / 3600.0 * 599.9, rel=1e-6)


def test_follower_dr_error_grows_to_the_configured_range() -> None:
    ends, early = [], []
    for seed in range(3):
        sim = simulate("paper-experiment", seed=seed)
        err = sim.truth.dr_error
        for pid in ("A", "C"):
            e = err[err["platform"] == pid]
            ends.append(e["error_h"].to_numpy()[-60:].mean())
            early.append(e["error_h"].to_numpy()[:60].mean())
        lead = err[err["platform"] == "B"]["error_h"]
        assert lead.quantile(0.95) < 0.1  # GNSS/INS: centimetres
    assert all(late > first for late, first in zip(ends, early, strict=True))
    assert 0.3 < float(np.median(ends)) < 1.5
    # the drawn errors are recorded and within the configured bounds
    params = sim.truth.dr_params
    assert set(params["platform"]) == {"A", "C"}
    assert (params["gyro_bias_dph"].abs().between(0.5 * 2.7, 2.7)).all()


def test_nlos_events_have_the_configured_means() -> None:
    sim = simulate("paper-table1", seed=3)
    events = sim.truth.nlos_events
    assert list(events["nominal_mean"]) == [0.45, 0.5, 0.6]
    assert list(events["epochs"]) == [100, 100, 50]  # 10 Hz, pair offset 13 ms
    dist = sim.truth.distances
    ranges = sim.session.ranges.frame
    assert np.allclose(ranges["range"] - dist["distance"], dist["error"])
    t_rel = dist["time"] - sim.truth.params.start_tow_s
    for row in events.itertuples():
        assert abs(row.realized_mean - row.nominal_mean) < 4 * 0.1 / np.sqrt(row.epochs)
        inside = (dist["time"] >= row.start) & (dist["time"] <= row.end)
        measured = dist.loc[inside, "error"].mean()
        assert measured == pytest.approx(
            row.nominal_mean, abs=4 * np.hypot(0.08, 0.1) / np.sqrt(row.epochs)
        )
    outside = ~(
        ((t_rel >= 10) & (t_rel <= 20))
        | ((t_rel >= 50) & (t_rel <= 60))
        | ((t_rel >= 90) & (t_rel <= 95))
    )
    assert abs(dist.loc[outside, "error"].mean()) < 0.02
    assert dist.loc[outside, "error"].std() == pytest.approx(0.08, rel=0.1)


def test_paper_experiment_events_and_line_of_sight() -> None:
    sim = simulate("paper-experiment", seed=0)
    events = sim.truth.nlos_events
    assert sorted(events["pair"]) == ["A-B", "A-B", "B-C", "B-C"]
    assert ((events["end"] - events["start"]).between(10, 30)).all()
    assert events["nominal_mean"].between(0.45, 0.6).all()
    dist = sim.truth.distances
    ac = dist[dist["pair"] == "A-C"]
    assert abs(ac["error"].mean()) < 0.02 and ac["error"].max() < 0.4
    assert dist["distance"].between(12.0, 28.0).all()
    assert dist["distance"].between(15.0, 25.0).mean() > 0.8
    ranges = sim.session.ranges.frame
    assert len(ranges) == pytest.approx(3 * 600 * 0.98, rel=0.03)  # 1 Hz, 2 % dropouts
    assert set(ranges.columns) >= {"time", "pair", "from", "to", "range", "sigma", "rssi"}
    assert (ranges["sigma"] == 0.15).all() and sim.session.config.uwb_sigma_m == 0.15


@pytest.mark.parametrize("rate", [0.1, 0.2])
def test_formation_distance_rate_is_as_configured(rate: float) -> None:
    sim = simulate("paper-experiment", seed=5, distance_rate_mps=rate)
    traj = sim.truth.trajectories
    pos = np.stack([traj[p].enu_m[::10] for p in ("A", "B", "C")])
    assert distance_rate_rms(pos, traj["A"].time_s[::10]) == pytest.approx(rate, rel=0.02)


def test_reference_has_fixed_and_float_epochs() -> None:
    sim = simulate("paper-experiment", seed=2)
    ref = sim.session.reference["A"]
    assert ref.quality is not None and set(np.unique(ref.quality)) == {1, 2}
    assert np.median(np.diff(ref.time_s)) == pytest.approx(0.2)
    fixed = ref.quality == 1
    assert 0.9 < fixed.mean() < 0.995
    err = ref.enu_m - sim.truth.trajectories["A"].interpolate(ref.time_s)
    assert np.std(err[fixed, 0]) == pytest.approx(0.01, rel=0.15)


def test_single_auxiliary_nav_is_in_its_own_frame() -> None:
    sim = simulate("single-auxiliary", seed=1, second_aux=True)
    nav = sim.session.nav["T"]
    assert np.hypot(*nav.enu_m[0, :2]) < 0.5  # starts at (about) its own origin
    frame = sim.truth.nav_frames.iloc[0]
    a = np.deg2rad(frame["rotation_deg"])
    e, n = nav.enu_m[:, 0], nav.enu_m[:, 1]
    back = np.column_stack(
        (
            e * np.cos(a) + n * np.sin(a) + frame["shift_east"],
            -e * np.sin(a) + n * np.cos(a) + frame["shift_north"],
        )
    )
    truth = sim.truth.trajectories["T"].enu_m[:, :2]
    dr = sim.truth.dr_error[sim.truth.dr_error["platform"] == "T"]
    assert np.allclose(np.hypot(*(back - truth).T)[::10], dr["error_h"], atol=1e-9)
    assert sim.session.platforms["T"].role == "follower"
    assert sim.session.platforms["A2"].role == "leader"
    dist = sim.truth.distances
    assert dist[dist["pair"] == "A2-T"]["error"].mean() == pytest.approx(0.6, abs=0.05)
    assert abs(dist[dist["pair"] == "A1-T"]["error"].mean()) < 0.03


def test_single_auxiliary_static_option() -> None:
    sim = simulate("single-auxiliary", seed=1, aux_static=True)
    a1 = sim.truth.trajectories["A1"].enu_m
    assert np.ptp(a1, axis=0).max() == 0.0
    assert set(sim.session.nav) == {"A1", "T"}


def test_anchors_scenario() -> None:
    sim = simulate("anchors", seed=0)
    anchors = [p for p in sim.session.platforms.values() if p.role == "anchor"]
    assert len(anchors) == 6 and all(p.position_enu_m is not None for p in anchors)
    assert set(sim.session.nav) == {"tag"} and set(sim.session.reference) == {"tag"}
    ranges = sim.session.ranges.frame
    t_rel = ranges["time"] - sim.truth.params.start_tow_s
    assert not ((t_rel >= 450) & (t_rel <= 480)).any()  # the outage
    assert set(sim.truth.nlos_events["pair"]) == {"AN3-tag"}
    assert len(sim.session.ranges.pairs) == 6


def test_gross_errors_are_recorded() -> None:
    sim = simulate("paper-experiment", seed=0, gross_error_rate=0.01, duration_s=300.0)
    gross = sim.truth.gross_errors
    assert len(gross) > 3
    assert gross["error"].abs().between(1.5, 2.5).all()
    merged = gross.merge(sim.truth.distances, on=["time", "pair"], suffixes=("_gross", ""))
    assert (np.sign(merged["error"]) == np.sign(merged["error_gross"])).all()


def test_large_scenario_shape() -> None:
    sim = simulate("large", seed=0, duration_s=600.0, platforms=6)
    assert len(sim.session.platforms) == 6
    assert len(sim.session.ranges.pairs) == 15
    assert len(sim.session.nav["P00"]) == 6001


def test_same_seed_same_session_other_seed_differs() -> None:
    one = simulate("paper-experiment", seed=7, duration_s=120.0)
    two = simulate("paper-experiment", seed=7, duration_s=120.0)
    three = simulate("paper-experiment", seed=8, duration_s=120.0)
    assert one.session.ranges.frame.equals(two.session.ranges.frame)
    assert np.array_equal(one.session.nav["A"].enu_m, two.session.nav["A"].enu_m)
    assert not np.array_equal(one.session.nav["A"].enu_m, three.session.nav["A"].enu_m)


def test_bad_parameters_are_one_line_config_errors() -> None:
    with pytest.raises(ConfigError, match="did you mean 'uwb_noise_m'"):
        simulate("paper-experiment", uwb_nose_m=0.1)
    with pytest.raises(ConfigError, match=r"unknown scenario 'paper-experimnt'.*paper-experiment"):
        simulate("paper-experimnt")
    with pytest.raises(ConfigError, match="platforms must be 2"):
        simulate("paper-table1", platforms=3)
    with pytest.raises(ConfigError, match="dropout_rate"):
        simulate("paper-experiment", dropout_rate=1.5)
    with pytest.raises(ConfigError, match="without ranging: A-Z"):
        simulate("paper-experiment", nlos_events=[("A-Z", 1.0, 2.0, 0.5)])
    assert set(SCENARIOS) == {
        "paper-experiment",
        "paper-table1",
        "anchors",
        "single-auxiliary",
        "multi-auxiliary",
        "large",
        "dr-faults",
        "noisy-leader",
        "body-blocked",
        "nav-gaps",
        "tag-only",
        "handcart",
        "land-vehicle",
        "quadrotor",
    }
