"""The scenarios that reproduce how processing fails on real data: each one's physics
against what it was configured with, from its truth (issue 10, item 8)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.errors import ConfigError
from coopproc.sim import NavGapSpec, simulate
from coopproc.sim.deadreckoning import DrErrors, Slip, dead_reckon
from coopproc.sim.uwb import nlos_mean_m
from tests.sim.quiet import quiet_params


def _heading_error_rate_dpm(nav_deg: np.ndarray, truth_deg: np.ndarray, t_s: np.ndarray) -> float:
    """Slope of the nav-minus-true heading over time, deg/min."""
    wrapped = np.unwrap(np.deg2rad(nav_deg - truth_deg))
    return float(np.polyfit((t_s - t_s[0]) / 60.0, np.rad2deg(wrapped), 1)[0])


def test_slip_over_reads_the_odometer_inside_the_episode() -> None:
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    enu = np.column_stack((np.zeros_like(t), 0.5 * t, np.zeros_like(t)))  # due north
    errors = DrErrors(0.0, 0.0, 0.0, (0.0, 0.0, 0.0), slips=(Slip(10.0, 14.0, 0.3),))
    dr, _, _ = dead_reckon(enu, t, quiet_params(), errors, np.random.default_rng(0))
    along = dr[:, 1] - enu[:, 1]
    assert np.allclose(along[t <= 10.0], 0.0)
    assert along[-1] == pytest.approx(0.3 * 0.5 * 4.0, rel=1e-9)  # 4 s at 0.5 m/s, +30 %
    assert np.allclose(dr[:, 0], 0.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_dr_faults_heading_rate_scale_and_slips(seed: int) -> None:
    sim = simulate("dr-faults", seed=seed)
    faults, drawn = sim.truth.nav_faults, sim.truth.dr_params.set_index("platform")
    followers = ["A", "C", "D"]
    assert sorted(drawn.index) == followers
    # heading-rate fault on A only: the nav heading error grows at the configured rate
    drift = faults[faults["fault"] == "heading_drift"]
    assert list(drift["platform"]) == ["A"] and abs(drift["value"].iloc[0]) == 3.0
    nav, truth = sim.session.nav["A"], sim.truth.trajectories["A"]
    expected = drift["value"].iloc[0] + drawn.loc["A", "gyro_bias_dph"] / 60.0
    rate = _heading_error_rate_dpm(nav.heading_deg, truth.heading_deg, nav.time_s)
    assert rate == pytest.approx(expected, abs=0.02)
    # odometer scale faults of 1-3 % on every follower, on top of the 0.3 % draw
    scale = faults[faults["fault"] == "odo_scale"].set_index("platform")["value"]
    assert sorted(scale.index) == followers
    assert scale.abs().between(0.01, 0.03).all()
    assert ((drawn.loc[followers, "odo_scale"] - scale).abs() < 4 * 0.003).all()
    # slips: 2-6 s, 20-50 % over-read, visible in the nav step lengths
    slips = faults[faults["fault"] == "slip"]
    assert len(slips) >= 3
    assert (slips["end"] - slips["start"]).between(2.0 - 1e-6, 6.0 + 1e-6).all()
    assert slips["value"].between(0.2, 0.5).all()
    for row in slips.itertuples():
        nav, truth = sim.session.nav[row.platform], sim.truth.trajectories[row.platform]
        inside = np.flatnonzero((nav.time_s > row.start) & (nav.time_s <= row.end))
        span = slice(inside[0] - 1, inside[-1] + 1)
        read = np.hypot(*np.diff(nav.enu_m[span, :2], axis=0).T).sum()
        true = np.hypot(*np.diff(truth.enu_m[span, :2], axis=0).T).sum()
        factor = (1 + drawn.loc[row.platform, "odo_scale"]) * (1 + row.value)
        assert read / true == pytest.approx(factor, abs=0.03)
    # the DR error grows far beyond the fault-free session's, the declaration does not
    err = sim.truth.dr_error
    assert err[err["platform"] == "A"]["error_h"].iloc[-1] > 10.0
    for pid in ("C", "D"):
        assert err[err["platform"] == pid]["error_h"].max() > 0.5
    plain = simulate("paper-experiment", seed=seed, platforms=4).session.platforms
    for pid in followers:
        assert sim.session.platforms[pid].drift_sigma_mps == plain[pid].drift_sigma_mps


def test_noisy_leader_has_white_noise_and_velocities() -> None:
    sim = simulate("noisy-leader", seed=2)
    nav, truth = sim.session.nav["B"], sim.truth.trajectories["B"]
    err = nav.enu_m - truth.enu_m
    # sample-to-sample differences see the white part (the 10 s Gauss-Markov part adds
    # 2 x 0.02^2 x (1 - exp(-0.01)) ~ (0.003 m)^2 to the variance of a difference)
    white = np.std(np.diff(err, axis=0), axis=0) / np.sqrt(2.0)
    assert white == pytest.approx([0.025, 0.025, 0.025], rel=0.05)
    assert np.std(err[:, 0]) == pytest.approx(np.hypot(0.02, 0.025), rel=0.3)
    assert nav.vel_enu_mps is not None
    vel_err = nav.vel_enu_mps - np.gradient(truth.enu_m, truth.time_s, axis=0)
    assert np.std(vel_err, axis=0) == pytest.approx([0.02, 0.02, 0.02], rel=0.05)
    # velocity by differences of positions at 10 Hz is far noisier than the speed
    by_diff = np.diff(nav.enu_m, axis=0) / 0.1 - np.diff(truth.enu_m, axis=0) / 0.1
    assert np.std(by_diff[:, 0]) > 0.3
    # the followers keep dead reckoning without velocity; the NLOS events are the paper's
    assert sim.session.nav["A"].vel_enu_mps is None
    assert sorted(sim.truth.nlos_events["pair"]) == ["A-B", "A-B", "B-C", "B-C"]
    declared = sim.session.platforms["B"].drift_sigma_mps
    assert declared == pytest.approx(np.hypot(0.0087, np.sqrt(2) * 0.025), abs=1e-3)
    sigma = nav.sigma_enu_m
    assert sigma is not None and sigma[0, 0] == pytest.approx(np.hypot(0.02, 0.025))


def test_body_blocked_pairs_of_d_are_in_long_wandering_nlos() -> None:
    sim = simulate("body-blocked", seed=3)
    params = sim.truth.params
    events = sim.truth.nlos_events
    assert set(sim.session.platforms) == {"A", "B", "C", "D"}
    assert set(events["pair"]) == {"A-D", "B-D", "C-D"}
    length = events["end"] - events["start"]
    long_one = events[events["pair"] == "B-D"]
    assert len(long_one) == 1 and float((long_one["end"] - long_one["start"]).iloc[0]) == 540.0
    others = length[events["pair"] != "B-D"]
    assert others.between(60.0, 200.0).all()
    assert (events["epochs"] > 0.9 * length).all()  # 1 Hz, 2 % dropouts
    dist = sim.truth.distances
    for spec in params.nlos_events:
        t_rel = np.arange(spec.start_s, spec.end_s, 1.0)
        mu = nlos_mean_m(spec, t_rel, 3)
        assert mu.min() >= 0.3 - 1e-9 and mu.max() <= 1.0
        assert np.abs(np.diff(mu)).max() < 0.03  # slow: < 3 cm per second
        assert mu.max() - mu.min() > 0.5 * spec.wander_m  # not constant
        # the range errors follow mu(t): 20 s windows agree with it
        row = dist[dist["pair"] == spec.pair]
        t = row["time"].to_numpy() - params.start_tow_s
        inside = (t >= spec.start_s) & (t <= spec.end_s)
        window = inside & (t < spec.start_s + 20.0)
        mean_mu = nlos_mean_m(spec, t[window], 3).mean()
        assert row["error"].to_numpy()[window].mean() == pytest.approx(mean_mu, abs=0.09)
    line_of_sight = dist[~dist["pair"].str.contains("D")]
    assert abs(line_of_sight["error"].mean()) < 0.01


def test_body_blocked_needs_platform_d() -> None:
    with pytest.raises(ConfigError, match="body-blocked: platforms must be 4"):
        simulate("body-blocked", platforms=3)


def test_nav_gaps_leave_out_nav_rows_but_not_ranges() -> None:
    sim = simulate("nav-gaps", seed=0)
    start = sim.truth.params.start_tow_s
    nav_a, nav_c = sim.session.nav["A"], sim.session.nav["C"]
    t_a = nav_a.time_s - start
    assert not ((t_a >= 270.0) & (t_a <= 330.0)).any()
    assert np.diff(t_a).max() == pytest.approx(60.2)
    assert t_a[-1] == pytest.approx(600.0)
    t_c = nav_c.time_s - start
    assert t_c[-1] == pytest.approx(539.9) and np.diff(t_c).max() == pytest.approx(0.1)
    assert len(sim.session.nav["B"]) == 6001
    ranges = sim.session.ranges.frame
    t_r = ranges["time"] - start
    with_c = ranges["pair"].str.contains("C")
    assert t_r[with_c].max() > 598.0 and (with_c & (t_r > 540.0)).sum() > 100
    with_a = ranges["pair"].str.contains("A")
    assert (with_a & t_r.between(270.0, 330.0)).sum() > 100
    assert sim.session.reference["C"].time_s[-1] - start == pytest.approx(600.0)
    gaps = sim.truth.nav_faults
    assert list(gaps["fault"]) == ["nav_gap", "nav_gap"]
    assert list(gaps["value"]) == [601.0, 601.0]
    err = sim.truth.dr_error
    t_err = err[err["platform"] == "A"]["time"] - start
    assert not t_err.between(270.0, 330.0).any()


def test_nav_gaps_keep_their_length_and_reach_the_end_in_a_shorter_session() -> None:
    sim = simulate("nav-gaps", seed=0, duration_s=180.0)
    gaps = {g.platform: (g.start_s, g.end_s) for g in sim.truth.params.nav_gaps}
    assert gaps["A"] == pytest.approx((81.0, 141.0))
    assert gaps["C"] == pytest.approx((162.0, 180.0))
    with pytest.raises(ConfigError, match="no such platform"):
        simulate("paper-experiment", nav_gaps=[NavGapSpec("Z", 1.0, 2.0)])
    with pytest.raises(ConfigError, match="fewer than 2 nav epochs"):
        simulate("paper-experiment", duration_s=60.0, nav_gaps=[("A", 0.0, 60.0)])


@pytest.mark.parametrize(
    ("scenario", "options"),
    [
        ("paper-experiment", {"platforms": 4}),
        ("anchors", {}),
        ("single-auxiliary", {"second_aux": True}),
        ("large", {"platforms": 3, "duration_s": 600.0}),
        ("body-blocked", {}),
    ],
)
def test_exact_ranges_are_the_true_distances(scenario: str, options: dict[str, object]) -> None:
    options = {"duration_s": 200.0, **options}
    sim = simulate(scenario, seed=4, exact_ranges=True, **options)  # type: ignore[arg-type]
    ranges, truth = sim.session.ranges.frame, sim.truth.distances
    assert (ranges["range"].to_numpy() == truth["distance"].to_numpy()).all()
    assert (truth["error"] == 0.0).all()
    assert len(sim.truth.nlos_events) == 0 and len(sim.truth.gross_errors) == 0
    period = 1.0 / sim.truth.params.range_rate_hz
    per_pair = ranges.groupby("pair").size()
    assert (per_pair >= np.floor(sim.truth.params.duration_s / period)).all()  # no dropouts
    # and the rest of the session is the usual one
    usual = simulate(scenario, seed=4, **options)  # type: ignore[arg-type]
    for pid, nav in usual.session.nav.items():
        assert np.array_equal(nav.enu_m, sim.session.nav[pid].enu_m)
