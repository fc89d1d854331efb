"""The ranging stage end to end on small synthetic sessions, and its configuration."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import ConfigError, StageError
from coopproc.model import (
    DI_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    RANGES_OUT_COLUMNS,
    Platform,
    RangeTable,
    Session,
    SessionConfig,
    Trajectory,
    pair_name,
)
from coopproc.stages.ranging.stage import RangingConfig, ranging_config_from_toml, run_ranging

NLOS = (50.0, 70.0, 0.5)  # A-B: start s, end s, mean m


def _session(seed: int = 0, uwb_sigma: float | None = 0.15, anchor: bool = True):
    """A (follower), B (leader) in a turning formation, C an anchor; 1 Hz ranges."""
    rng = np.random.default_rng(seed)
    tn = np.arange(0.0, 200.01, 0.1)
    heading = 0.01 * tn
    centre = np.column_stack([0.5 * tn * np.cos(heading), 0.5 * tn * np.sin(heading), 0 * tn])
    truth = {
        "A": centre + np.column_stack([-6 + np.sin(tn / 9), 8 + 0 * tn, 0 * tn]),
        "B": centre + np.column_stack([6 + 0 * tn, np.cos(tn / 13), 0 * tn]),
    }
    drift = np.column_stack([0.004 * tn, -0.003 * tn, 0 * tn])
    nav = {
        "A": Trajectory("A", tn, truth["A"] + drift),
        "B": Trajectory("B", tn, truth["B"] + rng.normal(0, 0.003, (tn.size, 3))),
    }
    cp = {p: Trajectory(p, tn, truth[p] + rng.normal(0, 0.01, (tn.size, 3))) for p in truth}
    ref = {p: Trajectory(p, tn, truth[p].copy()) for p in truth}
    anchor_pos = (0.0, 30.0, 0.0)
    tr = np.arange(0.0, 200.0, 1.0)
    rows = []
    pairs = [("A", "B")] + ([("A", "C"), ("B", "C")] if anchor else [])
    for a, b in pairs:
        pa = ref[a].interpolate(tr)
        pb = ref[b].interpolate(tr) if b != "C" else np.tile(anchor_pos, (tr.size, 1))
        dist = np.linalg.norm(pa - pb, axis=1)
        meas = dist + rng.normal(0, 0.08, tr.size)
        if (a, b) == ("A", "B"):
            inside = (tr >= NLOS[0]) & (tr < NLOS[1])
            meas[inside] += rng.normal(NLOS[2], 0.05, inside.sum())
        for k in range(tr.size):
            first, second = (a, b) if k % 2 == 0 else (b, a)  # both directions
            rows.append((tr[k] + 0.01 * (k % 2), pair_name(a, b), first, second, meas[k]))
    frame = pd.DataFrame(rows, columns=["time", "pair", "from", "to", "range"])
    frame["sigma"] = np.nan
    frame = frame.sort_values("time", kind="stable").reset_index(drop=True)
    platforms = {"A": Platform("A", "follower", 0.005), "B": Platform("B", "leader", 0.005)}
    if anchor:
        platforms["C"] = Platform("C", "anchor", None, anchor_pos)
    config = SessionConfig(name="synthetic", platforms=platforms, uwb_sigma_m=uwb_sigma)
    session = Session(
        config=config,
        platforms=platforms,
        nav=nav,
        reference=ref,
        ranges=RangeTable(frame),
        origin_llh=(0.0, 0.0, 0.0),
        root=Path("synthetic"),
    )
    return session, cp


@pytest.fixture(scope="module")
def result():
    session, cp = _session()
    return session, run_ranging(session, cp, RangingConfig())


def test_tables_follow_the_data_contract(result) -> None:
    session, out = result
    assert tuple(out.ranges.columns) == RANGES_OUT_COLUMNS
    assert tuple(out.di.columns) == DI_COLUMNS
    assert tuple(out.nlos_events.columns) == NLOS_EVENT_COLUMNS
    assert tuple(out.nlos_estimates.columns) == NLOS_ESTIMATE_COLUMNS
    assert len(out.ranges) == len(session.ranges)
    keys = list(zip(out.ranges["pair"], out.ranges["time"], strict=True))
    assert keys == sorted(keys)
    assert set(out.nlos_events["method"]) <= {"di", "rn"}
    # the white UWB noise from the data (simulated 0.08 m), the declared 0.15 m a prior
    for pair in ("A-B", "A-C", "B-C"):
        sigma, source = out.sigma[pair]
        assert source == "data"
        assert sigma == pytest.approx(0.08, rel=0.25)
        cal = out.calibration[(pair, "di")]
        assert cal.declared_sigma_m == 0.15
        assert cal.white_sigma_m == sigma
        assert cal.white_sigma_m <= cal.detect_sigma_m <= 0.15


def test_nlos_event_detected_and_estimated(result) -> None:
    _, out = result
    ev = out.nlos_events
    di = ev[(ev["pair"] == "A-B") & (ev["method"] == "di")]
    assert len(di) == 1
    assert di["start"].iloc[0] == pytest.approx(NLOS[0], abs=1.1)
    assert di["end"].iloc[0] == pytest.approx(NLOS[1] - 1.0, abs=1.1)
    # eq. (12) over M = 3 s (3 epochs at 1 Hz): the mean NLOS error of those epochs, up to
    # the DI propagation error
    ab = out.ranges[out.ranges["pair"] == "A-B"]
    first = ab[(ab["time"] >= NLOS[0]) & (ab["time"] < NLOS[0] + 3.0)]
    oracle = (first["observed"] - first["reference"]).mean()
    assert di["estimate"].iloc[0] == pytest.approx(oracle, abs=0.02)
    assert di["estimate"].iloc[0] == pytest.approx(NLOS[2], rel=0.25)
    # no event on the line-of-sight pairs, no flag outside the event
    assert set(ev.loc[ev["method"] == "di", "pair"]) == {"A-B"}
    rg = out.ranges
    outside = (rg["time"] < NLOS[0] - 1) | (rg["time"] > NLOS[1] + 1)
    assert rg.loc[outside, "nlos_flag"].sum() == 0
    # estimate after each step of eq. (11): M = 3 s at 1 Hz -> 3 steps, the last = estimate
    steps = out.nlos_estimates
    steps = steps[(steps["pair"] == "A-B") & (steps["method"] == "di")]
    assert steps["step"].tolist() == [1, 2, 3]
    assert steps["estimate"].iloc[-1] == pytest.approx(di["estimate"].iloc[0])


def test_processed_ranges_beat_the_observed(result) -> None:
    _, out = result
    for pair, g in out.ranges.groupby("pair"):
        err_obs = g["observed"] - g["reference"]
        err_di = g["di"] - g["reference"]
        assert np.sqrt(np.mean(err_di**2)) < 0.6 * np.sqrt(np.mean(err_obs**2)), pair
        if pair == "A-B":
            assert err_di.abs().max() < 0.4 * err_obs.abs().max()


def test_di_table(result) -> None:
    _, out = result
    d = out.di[out.di["pair"] == "A-C"]
    ref = out.ranges[out.ranges["pair"] == "A-C"]["reference"].to_numpy()
    assert d["di_reference"].to_numpy()[1:] == pytest.approx(np.diff(ref))
    assert np.isnan(d["di_dr"].iloc[0])
    err = (d["di_smoothed"] - d["di_reference"]).to_numpy()[1:]
    assert np.sqrt(np.mean(err**2)) < 0.01


def test_deterministic() -> None:
    session, cp = _session(seed=3)
    a = run_ranging(session, cp, RangingConfig())
    b = run_ranging(session, cp, RangingConfig())
    pd.testing.assert_frame_equal(a.ranges, b.ranges)
    pd.testing.assert_frame_equal(a.nlos_events, b.nlos_events)


def test_sigma_sources() -> None:
    session, cp = _session(uwb_sigma=None, anchor=False)
    out = run_ranging(session, cp, RangingConfig())
    sigma, source = out.sigma["A-B"]
    assert source == "data"
    assert sigma == pytest.approx(0.08, rel=0.3)
    off = {"self_calibrate": False}
    cfg = ranging_config_from_toml({"ranging": {"nlos": off}, "fusion": {}})
    sigma, source = run_ranging(session, cp, cfg).sigma["A-B"]
    assert source == "adaptive"
    assert sigma == pytest.approx(0.08, rel=0.3)
    cfg = ranging_config_from_toml({"ranging": {"nlos": {**off, "adaptive": False}}})
    out = run_ranging(session, cp, cfg)
    assert out.sigma["A-B"] == (0.15, "default")


def test_missing_navigation_is_a_stage_error() -> None:
    session, cp = _session(anchor=False)
    broken = replace(session, nav={"A": session.nav["A"]})
    with pytest.raises(StageError, match="no navigation for platform 'B'"):
        run_ranging(broken, cp, RangingConfig())


def test_config_from_toml() -> None:
    cfg = ranging_config_from_toml(
        {"ranging": {"nlos": {"gamma_sigma": 2.0, "window_s": 5}, "distance": {}}}
    )
    assert cfg.nlos.gamma_sigma == 2.0 and cfg.nlos.window_s == 5.0
    assert ranging_config_from_toml({}) == RangingConfig()
    assert RangingConfig().nlos.gamma_sigma == 3.0 and RangingConfig().nlos.window_s == 3.0
    with pytest.raises(ConfigError, match="did you mean 'gamma_sigma'"):
        ranging_config_from_toml({"ranging": {"nlos": {"gama_sigma": 3}}})
    with pytest.raises(ConfigError, match="is not one of"):
        ranging_config_from_toml({"ranging": {"distance": {"transition": "late"}}})


def test_reference_is_empty_inside_reference_gaps() -> None:
    session, cp = _session(anchor=False)
    ref_a = session.reference["A"]
    keep = (ref_a.time_s < 100.0) | (ref_a.time_s > 105.0)  # e.g. dropped float epochs
    gappy = Trajectory("A", ref_a.time_s[keep], ref_a.enu_m[keep])
    out = run_ranging(replace(session, reference={**session.reference, "A": gappy}), cp,
                      RangingConfig())  # fmt: skip
    rg = out.ranges
    inside = (rg["time"] >= 100.0) & (rg["time"] < 105.1)  # samples resume at 105.1
    assert rg.loc[inside, "reference"].isna().all()
    assert rg.loc[~inside, "reference"].notna().all()


def test_duplicate_epochs_and_a_single_range_pair() -> None:
    session, cp = _session()
    frame = session.ranges.frame
    ab = frame[frame["pair"] == "A-B"].iloc[:40]
    twice = ab.assign(range=ab["range"] + 0.01)  # a second range at the same times
    lone = frame[frame["pair"] == "A-C"].iloc[:1]
    rows = pd.concat([ab, twice, lone]).sort_values("time", kind="stable")
    out = run_ranging(replace(session, ranges=RangeTable(rows.reset_index(drop=True))), cp,
                      RangingConfig())  # fmt: skip
    assert len(out.ranges) == 81
    assert out.ranges["di"].notna().all()
    got = out.ranges[out.ranges["pair"] == "A-B"]
    assert np.sqrt(np.mean((got["di"] - got["reference"]) ** 2)) < 0.08
    assert out.ranges.loc[out.ranges["pair"] == "A-C", "di"].iloc[0] == lone["range"].iloc[0]
