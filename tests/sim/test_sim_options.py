"""Every simulation parameter acts in every scenario, or is refused there in one line
(issue 16, item 4); outages apply everywhere; a shorter session keeps only the events,
outages and gaps that still hold epochs."""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.sim import SCENARIOS, SimParams, Simulation, simulate
from coopproc.sim.options import GNSS_OPTIONS

#: Short sessions of every scenario (120 s: random NLOS events and float reference
#: segments need more than a minute; paper-table1's three events would leave random
#: ones no room in 120 s).
_BASE: dict[str, dict[str, Any]] = {
    "paper-experiment": {"duration_s": 120.0},
    "paper-table1": {"duration_s": 240.0},
    "anchors": {"duration_s": 120.0},
    "tag-only": {"duration_s": 120.0},
    # without their default IMU files (half the simulation time; imu_rate_hz is in the
    # matrix, and the IMU parameters get it from _NEEDS)
    "handcart": {"duration_s": 120.0, "imu_rate_hz": 0.0},
    "land-vehicle": {"duration_s": 120.0, "imu_rate_hz": 0.0},
    "single-auxiliary": {"duration_s": 120.0},
    "multi-auxiliary": {"duration_s": 120.0},
    "large": {"duration_s": 120.0, "platforms": 3},
    "dr-faults": {"duration_s": 120.0},
    "noisy-leader": {"duration_s": 120.0},
    "body-blocked": {"duration_s": 120.0},
    "nav-gaps": {"duration_s": 120.0},
    "quadrotor": {"duration_s": 120.0, "imu_rate_hz": 0.0, "platforms": 8},
}

Value = Callable[[Simulation], Any]


def _pair(sim: Simulation) -> str:
    return sorted(sim.session.ranges.pairs)[0]


def _navigating(sim: Simulation) -> str:
    return sorted(sim.session.nav)[0] if sim.session.nav else "tag"  # tag-only: no nav


def _flip(name: str) -> Value:
    return lambda sim: not getattr(sim.truth.params, name)


#: A value of every parameter unlike any scenario's (a function of the base session).
_CHANGE: dict[str, Value] = {
    "duration_s": lambda sim: 90.0,
    "platforms": lambda sim: sim.truth.params.platforms + 1,
    "gps_week": lambda sim: 2200,
    "start_tow_s": lambda sim: 200000.0,
    "origin_llh": lambda sim: [35.0, 114.0, 50.0],
    "nav_rate_hz": lambda sim: 5.0,
    "range_rate_hz": lambda sim: 2.0,
    "ref_rate_hz": lambda sim: 1.0,
    "speed_mps": lambda sim: 0.8 if sim.truth.params.speed_mps != 0.8 else 1.0,
    "distance_rate_mps": lambda sim: 0.2,
    "height_amplitude_m": lambda sim: 1.0,
    "gyro_bias_dph": lambda sim: 10.0,
    "gyro_arw_dpsh": lambda sim: 1.0,
    "heading_init_sigma_deg": lambda sim: 1.0,
    "odo_scale_sigma": lambda sim: 0.01,
    "odo_noise_m": lambda sim: 0.02,
    "init_error_m": lambda sim: 0.5,
    "height_rw_m": lambda sim: 0.01,
    "heading_drift_dpm": lambda sim: 5.0,
    "odo_scale_fault": lambda sim: [0.04, 0.05],
    "slip_rate_per_hour": lambda sim: 600.0,
    "nav_gaps": lambda sim: [[_navigating(sim), 30.0, 40.0]],
    "leader_sigma_m": lambda sim: 0.1,
    "leader_sigma_up_m": lambda sim: 0.1,
    "leader_corr_s": lambda sim: 30.0,
    "leader_white_m": lambda sim: 0.05,
    "leader_velocity": _flip("leader_velocity"),
    "leader_vel_sigma_mps": lambda sim: 0.1,
    "uwb_noise_m": lambda sim: 0.2,
    "uwb_declared_sigma_m": lambda sim: 0.3,
    "dropout_rate": lambda sim: 0.1,
    "gross_error_rate": lambda sim: 0.05,
    "gross_error_m": lambda sim: 5.0,
    "nlos_sigma_m": lambda sim: 0.3,
    "nlos_events": lambda sim: [[_pair(sim), 20.0, 60.0, 0.5]],
    "random_nlos_per_pair_hour": lambda sim: 600.0,
    "outages": lambda sim: [[30.0, 50.0]],
    "rssi": _flip("rssi"),
    "exact_ranges": _flip("exact_ranges"),
    "ref_sigma_m": lambda sim: 0.05,
    "ref_sigma_up_m": lambda sim: 0.05,
    "float_fraction": lambda sim: 0.2,
    "float_sigma_m": lambda sim: 0.3,
    "aux_static": _flip("aux_static"),
    "second_aux": _flip("second_aux"),
    "aux2_bias_m": lambda sim: 1.0,
    "aux2_noise_m": lambda sim: 0.5,
    "aux_distance_m": lambda sim: 30.0,
    "aux1_moves_at_s": lambda sim: 30.0,
    "aux3_tail_m": lambda sim: 0.4,
    "imu_rate_hz": lambda sim: 50.0,
    # unlike the scenario's own (handcart: tactical)
    "imu_grade": lambda sim: "consumer" if sim.truth.params.imu_grade != "consumer" else "tactical",
    "imu_earth_rate": _flip("imu_earth_rate"),
    "odo_rate_hz": lambda sim: 20.0,
    "imu_body": lambda sim: "vehicle" if sim.truth.params.imu_body != "vehicle" else "multirotor",
}


def _single_only(value: Any) -> Value:
    """``value`` in single-auxiliary, not set elsewhere (multi-auxiliary has A2 already)."""
    return lambda sim: value if sim.scenario == "single-auxiliary" else None


#: What a parameter needs to act (set in both runs where it applies; None: not set).
_NEEDS: dict[str, dict[str, Value]] = {
    "leader_vel_sigma_mps": {"leader_velocity": lambda sim: True},
    "gross_error_m": {"gross_error_rate": lambda sim: 0.05},
    "nlos_sigma_m": {"nlos_events": _CHANGE["nlos_events"]},
    "aux2_bias_m": {"second_aux": _single_only(True)},
    "aux2_noise_m": {"second_aux": _single_only(True)},
    "imu_grade": {"imu_rate_hz": lambda sim: 50.0},
    "imu_earth_rate": {"imu_rate_hz": lambda sim: 50.0},
    "odo_rate_hz": {"imu_rate_hz": lambda sim: 50.0, "imu_body": lambda sim: "vehicle"},
    "imu_body": {"imu_rate_hz": lambda sim: 50.0},
}

_AUX = ("aux_static", "second_aux", "aux2_bias_m", "aux2_noise_m")
_MULTI = ("aux_distance_m", "aux1_moves_at_s", "aux3_tail_m")
_AUX_SCENARIOS = ("single-auxiliary", "multi-auxiliary")
_LEADER = (
    "leader_sigma_m", "leader_sigma_up_m", "leader_corr_s", "leader_white_m",
    "leader_velocity", "leader_vel_sigma_mps",
)  # fmt: skip
#: the dead-reckoning model's parameters: nothing to act on in tag-only
_TAG_DR = (
    "gyro_bias_dph", "gyro_arw_dpsh", "heading_init_sigma_deg", "odo_scale_sigma",
    "odo_noise_m", "init_error_m", "height_rw_m", "heading_drift_dpm", "odo_scale_fault",
    "slip_rate_per_hour", "nav_gaps",
)  # fmt: skip
#: (parameter, scenario) -> what the refusal says besides the parameter's name
_REFUSED: dict[tuple[str, str], str] = {
    **{
        (o, s): "applies to: single-auxiliary, multi-auxiliary"
        for o in _AUX
        for s in SCENARIOS
        if s not in _AUX_SCENARIOS and o != "second_aux"
    },
    **{
        ("second_aux", s): "applies to: single-auxiliary"
        for s in SCENARIOS
        if s != "single-auxiliary"
    },
    ("second_aux", "multi-auxiliary"): "set by the platform count",
    **{
        (o, s): "applies to: multi-auxiliary"
        for o in _MULTI
        for s in SCENARIOS
        if s != "multi-auxiliary"
    },
    ("distance_rate_mps", "multi-auxiliary"): "no formation",
    ("platforms", "multi-auxiliary"): "must be 2..4",
    **{(o, "anchors"): "no GNSS/INS platform" for o in _LEADER},
    ("distance_rate_mps", "anchors"): "no formation",
    **{(o, s): "no GNSS/INS platform" for o in _LEADER for s in ("handcart", "land-vehicle")},
    ("distance_rate_mps", "handcart"): "no formation",
    ("distance_rate_mps", "land-vehicle"): "no formation",
    **{(o, "tag-only"): "no GNSS/INS platform" for o in _LEADER},
    **{(o, "tag-only"): "the tag has no dead reckoning" for o in _TAG_DR},
    ("distance_rate_mps", "tag-only"): "no formation",
    ("distance_rate_mps", "single-auxiliary"): "no formation",
    ("platforms", "paper-table1"): "must be 2",
    **{(o, "quadrotor"): "no GNSS/INS platform" for o in _LEADER},
    **{(o, "quadrotor"): "the tag has no dead reckoning" for o in _TAG_DR},
    ("distance_rate_mps", "quadrotor"): "no formation",
    ("height_amplitude_m", "quadrotor"): "no terrain",
}


def _digest(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, pd.DataFrame):
            for name in part.columns:
                values = part[name].to_numpy()
                h.update(str(name).encode())
                if values.dtype.kind in "biuf":
                    h.update(np.ascontiguousarray(values).tobytes())
                else:
                    h.update("\x1f".join(map(str, values)).encode())
        elif isinstance(part, np.ndarray):
            h.update(np.ascontiguousarray(part).tobytes())
        else:
            h.update(repr(part).encode())
    return h.hexdigest()


def _content(sim: Simulation) -> dict[str, str]:
    """A digest of everything the session and truth files are written from, but the
    parameters (``truth/params.toml`` and the README command record the option itself)."""
    session, truth = sim.session, sim.truth
    out = {"session.toml": _digest(session.config, session.platforms, session.origin_llh)}
    out["ranges"] = _digest(session.ranges.frame)
    for kind, trajectories in (
        ("nav", session.nav),
        ("ref", session.reference),
        ("truth/traj", truth.trajectories),
    ):
        for pid, traj in trajectories.items():
            arrays = (traj.time_s, traj.enu_m, traj.sigma_enu_m, traj.vel_enu_mps)
            out[f"{kind}_{pid}"] = _digest(*arrays, traj.heading_deg, traj.quality)
    for pid, imu in session.imu.items():
        out[f"imu_{pid}"] = _digest(imu.time_s, imu.gyro_radps, imu.accel_mps2)
    for pid, odo in session.odometer.items():
        out[f"odo_{pid}"] = _digest(odo.time_s, odo.speed_mps)
    for f in dataclasses.fields(truth):
        value = getattr(truth, f.name)
        if isinstance(value, pd.DataFrame):
            out[f"truth/{f.name}"] = _digest(value)
    return out


def _run(scenario: str, extra: dict[str, Any]) -> Simulation:
    return simulate(scenario, seed=0, **{**_BASE[scenario], **extra})


_PLAIN: dict[str, Simulation] = {}
_BASE_CONTENT: dict[tuple[str, str], dict[str, str]] = {}


def _plain(scenario: str) -> Simulation:
    if scenario not in _PLAIN:
        _PLAIN[scenario] = _run(scenario, {})
    return _PLAIN[scenario]


def _base_content(scenario: str, extra: dict[str, Any]) -> dict[str, str]:
    key = (scenario, repr(sorted(extra.items())))
    if key not in _BASE_CONTENT:
        _BASE_CONTENT[key] = _content(_run(scenario, extra) if extra else _plain(scenario))
    return _BASE_CONTENT[key]


def test_every_parameter_is_in_the_matrix() -> None:
    # but the GNSS observation parameters: a GNSS session costs seconds, they are checked
    # (acting, refused without gnss_obs) in tests/sim/test_gnss_obs.py
    gnss = {"gnss_obs", *GNSS_OPTIONS}
    names = [f.name for f in dataclasses.fields(SimParams) if f.name not in gnss]
    assert sorted(_CHANGE) == sorted(names)


@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
@pytest.mark.parametrize("option", sorted(_CHANGE))
def test_option_acts_or_is_refused(option: str, scenario: str) -> None:
    plain = _plain(scenario)
    value = _CHANGE[option](plain)
    refusal = _REFUSED.get((option, scenario))
    if refusal is not None:
        with pytest.raises(ConfigError) as caught:
            _run(scenario, {option: value})
        message = str(caught.value)
        assert f"'{option}'" in message or f"{option} must" in message, message
        assert refusal in message and "\n" not in message
        return
    needs = {key: make(plain) for key, make in _NEEDS.get(option, {}).items()}
    needs = {key: value for key, value in needs.items() if value is not None}
    changed = _content(_run(scenario, {**needs, option: value}))
    base = _base_content(scenario, needs)
    assert changed != base, f"{option}={value!r} changes nothing in {scenario}"


@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_outages_apply_in_every_scenario(scenario: str) -> None:
    sim = _run(scenario, {"outages": [[30.0, 50.0], [80.0, 81.5]]})
    start = sim.truth.params.start_tow_s
    for table in (sim.session.ranges.frame, sim.truth.distances):
        t = table["time"].to_numpy() - start
        assert not ((t >= 30.0) & (t <= 50.0)).any()
        assert not ((t >= 80.0) & (t <= 81.5)).any()
        assert (t < 30.0).any() and ((t > 50.0) & (t < 80.0)).any() and (t > 81.5).any()
    # and exact ranges have none
    exact = _run(scenario, {"exact_ranges": True})
    t = exact.session.ranges.frame["time"].to_numpy() - start
    assert ((t >= 30.0) & (t <= 50.0)).any()


def test_the_anchors_outage_moves_with_the_session_length() -> None:
    sim = simulate("anchors", seed=0, duration_s=120.0)
    (outage,) = sim.truth.params.outages
    assert (outage.start_s, outage.end_s) == pytest.approx((90.0, 119.0))
    t = sim.session.ranges.frame["time"] - sim.truth.params.start_tow_s
    assert not t.between(90.0, 119.0).any() and (t > 119.0).any()


def test_a_five_second_session_lists_only_the_events_it_holds(tmp_path: Path) -> None:
    out = tmp_path / "s"
    args = ["simulate", str(out), "--scenario", "paper-experiment", "--duration", "5"]
    made = CliRunner().invoke(main, args)
    assert made.exit_code == 0, made.output
    assert "2 NLOS events" in made.output
    events = pd.read_csv(out / "truth" / "nlos_events.csv")
    assert list(events["pair"]) == ["A-B", "B-C"] and (events["epochs"] > 0).all()
    params = (out / "truth" / "params.toml").read_text()
    assert params.count("mean_m =") == 2
    readme = (out / "README.md").read_text()
    assert readme.count("| A-B |") + readme.count("| B-C |") == 2


@pytest.mark.parametrize("duration", [3.0, 5.0, 12.0, 33.3])
@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_short_sessions_keep_what_still_holds_epochs(scenario: str, duration: float) -> None:
    kwargs: dict[str, Any] = {"platforms": 3} if scenario == "large" else {}
    sim = simulate(scenario, seed=1, duration_s=duration, dropout_rate=0.0, **kwargs)
    params, truth = sim.truth.params, sim.truth
    ranges = truth.distances
    t = ranges["time"].to_numpy() - params.start_tow_s
    # without dropouts every event kept holds ranges of its pair, and the truth lists it
    assert len(truth.nlos_events) == len(params.nlos_events)
    assert (truth.nlos_events["epochs"] > 0).all()
    for event in params.nlos_events:
        assert 0.0 <= event.start_s < event.end_s <= duration
    for outage in params.outages:
        assert 0.0 <= outage.start_s < outage.end_s <= duration
        assert not ((t >= outage.start_s) & (t <= outage.end_s)).any()
    faults = truth.nav_faults
    assert (faults[faults["fault"] == "nav_gap"]["value"] > 0).all()
    session_end = params.start_tow_s + duration
    assert faults["start"].between(params.start_tow_s, session_end).all()
    assert faults["end"].between(params.start_tow_s, session_end + 1e-6).all()


def test_given_events_outages_and_gaps_outside_the_session_are_refused() -> None:
    cases = [
        ({"nlos_events": [["A-B", 700.0, 710.0, 0.5]]}, "'nlos_events': the event on A-B"),
        ({"nlos_events": [["A-B", 10.5, 10.9, 0.5]]}, "holds no range of the pair"),
        ({"outages": [[700.0, 730.0]]}, "'outages': the outage at 700-730 s removes no range"),
        ({"nav_gaps": [["A", 700.0, 730.0]]}, "'nav_gaps': the gap of A at 700-730 s"),
        ({"nav_gaps": [["A", 10.01, 10.05]]}, "removes no nav row"),
        ({"outages": [[130.0, 100.0]]}, "ends before it starts"),
    ]
    for options, message in cases:
        with pytest.raises(ConfigError, match=message):
            simulate("paper-experiment", **options)
    # partly inside: used as given
    sim = simulate("paper-experiment", outages=[[590.0, 700.0]], nlos_events=[["A-C", 595, 650]])
    t = sim.session.ranges.frame["time"] - sim.truth.params.start_tow_s
    assert t.max() < 590.0
    assert len(sim.truth.nlos_events) == 0  # its epochs all fell in the outage


@pytest.mark.parametrize(
    ("scenario", "options", "message"),
    [
        ("paper-experiment", {"gross_error_m": 3.0}, "without gross errors"),
        ("paper-experiment", {"leader_vel_sigma_mps": 0.1}, "leader_velocity = false"),
        ("noisy-leader", {"leader_velocity": False, "leader_vel_sigma_mps": 0.1}, "leader_vel"),
        ("single-auxiliary", {"aux2_bias_m": 1.0}, "second_aux = true or --platforms 3"),
        ("single-auxiliary", {"aux2_noise_m": 1.0}, "without the second auxiliary A2"),
        ("paper-experiment", {"float_fraction": 0.0, "float_sigma_m": 0.2}, "float_fraction = 0"),
        ("paper-experiment", {"duration_s": 60.0, "float_fraction": 0.1}, "more than 60 s"),
        ("paper-experiment", {"duration_s": 60.0, "float_sigma_m": 0.2}, "more than 60 s"),
        ("large", {"duration_s": 100.0, "random_nlos_per_pair_hour": 5.0}, "120 s or more"),
        ("dr-faults", {"duration_s": 20.0, "slip_rate_per_hour": 50.0}, "more than 20 s"),
        ("single-auxiliary", {"nlos_sigma_m": 0.2}, "without NLOS events"),
        ("multi-auxiliary", {"platforms": 3, "aux3_tail_m": 0.3}, "without the third auxiliary"),
        ("multi-auxiliary", {"aux_static": True, "aux1_moves_at_s": 50.0}, "aux_static = true"),
        ("multi-auxiliary", {"aux1_moves_at_s": 400.0}, "at or after the session end"),
        ("paper-experiment", {"nlos_events": [], "nlos_sigma_m": 0.2}, "without NLOS events"),
    ],
)
def test_parameters_that_need_another_are_refused_without_it(
    scenario: str, options: dict[str, Any], message: str
) -> None:
    option = [k for k in options if k != "duration_s"][-1]
    with pytest.raises(ConfigError, match=message) as caught:
        simulate(scenario, **options)
    assert f"simulation parameter '{option}' does nothing" in str(caught.value)


@pytest.mark.parametrize(
    "option",
    [
        "uwb_noise_m", "dropout_rate", "gross_error_rate", "gross_error_m", "nlos_sigma_m",
        "nlos_events", "random_nlos_per_pair_hour", "outages", "aux2_bias_m", "aux2_noise_m",
    ],
)  # fmt: skip
def test_range_errors_are_refused_with_exact_ranges(option: str) -> None:
    plain = _run("single-auxiliary", {"second_aux": True})
    value = _CHANGE[option](plain)
    with pytest.raises(ConfigError, match=f"'{option}' does nothing with exact_ranges = true"):
        _run("single-auxiliary", {"second_aux": True, "exact_ranges": True, option: value})


def test_cli_refuses_in_one_line_and_takes_duration_from_set(tmp_path: Path) -> None:
    runner = CliRunner()
    out = str(tmp_path / "s")
    refused = runner.invoke(
        main, ["simulate", out, "--scenario", "paper-experiment", "--set", "aux_static=true"]
    )
    assert refused.exit_code == 1
    assert refused.output.strip().splitlines() == [
        "error: simulation parameter 'aux_static' does nothing in scenario 'paper-experiment' "
        "(no auxiliary A1/A2); it applies to: single-auxiliary, multi-auxiliary"
    ]
    both = runner.invoke(
        main,
        ["simulate", out, "--scenario", "paper-table1", "--duration", "9", "--set", "duration_s=8"],
    )
    assert both.exit_code == 1 and "--duration and --set duration_s both given" in both.output
    made = runner.invoke(
        main, ["simulate", out, "--scenario", "paper-table1", "--set", "duration_s=8"]
    )
    assert made.exit_code == 0, made.output
    assert "8 s, 2 platforms" in made.output
    readme = (tmp_path / "s" / "README.md").read_text()
    assert "coopproc simulate s --scenario paper-table1 --seed 0 --duration 8\n" in readme


def test_docs_say_where_each_parameter_applies() -> None:
    from coopproc.sim.options import NEEDS, RANGE_ERROR_OPTIONS

    docs = Path(__file__).resolve().parents[2] / "docs" / "simulator.md"
    text = docs.read_text(encoding="utf-8")
    section = text.split("## Which parameters apply where", 1)[1].split("\n## ", 1)[0]
    named = {o for spec in SCENARIOS.values() for o in spec.unused}
    for option in sorted(named | set(NEEDS) | set(RANGE_ERROR_OPTIONS) | {"nlos_sigma_m"}):
        assert f"`{option}`" in section, option
