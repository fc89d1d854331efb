"""Declared drifts checked against the data (issue 32.3): replaced beyond 10 x, with a note
saying both, unless [calibration] trust_declared; leaders not checked."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from coopproc.io.session_toml import parse_session_toml, session_toml_table
from coopproc.model import Session, Trajectory
from coopproc.run.calibration_summary import calibration_lines
from coopproc.run.config import RunConfig
from coopproc.run.declared import DECLARED_FACTOR, check_drifts, with_drifts
from coopproc.run.pipeline import run_pipeline
from coopproc.stages.fusion.fuse import FusionParams
from tests.stages.fusion.test_fusion import make_session


@pytest.fixture(scope="module")
def declared() -> tuple[Session, dict[str, Trajectory]]:
    """A 120 s session whose follower A declares 5 m/s (its navigation drifts ~0.005 m/s)
    and the true trajectories as the cooperative solution."""
    session, truth, epochs = make_session(duration_s=120.0)
    session = with_drifts(session, {"A": 5.0})
    fused = {p: Trajectory(p, epochs, pos) for p, pos in truth.items()}
    return session, fused


def test_a_drift_declared_far_too_large_is_replaced(declared) -> None:
    session, fused = declared
    checked, new, new_dr, redo = check_drifts(session, session, fused, FusionParams())
    assert set(checked.contradicted) == {"A"}  # C's 0.02 is within 10 x; B a leader
    given, estimate = checked.contradicted["A"]
    assert given == 5.0 and 0.001 < estimate < 5.0 / DECLARED_FACTOR
    assert checked.replaced and new_dr is new
    assert new.platforms["A"].drift_sigma_mps == estimate
    assert new.platforms["C"].drift_sigma_mps == 0.02  # not contradicted: as declared
    assert not redo  # with DR states the fusion does not use a follower's drift_sigma
    (note,) = checked.notes
    assert "A's declared drift_sigma 5.0000 m/s" in note
    assert f"({estimate:.4f} m/s" in note and f"{estimate:.4f} m/s used instead" in note
    # the position-only fusion's process noise is the drift: its fusion is run again
    assert check_drifts(session, session, fused, FusionParams(state="position"))[3]


def test_trust_declared_keeps_the_figure_and_says_so(declared) -> None:
    session, fused = declared
    config = dataclasses.replace(session.config, trust_declared=True)
    trusted = dataclasses.replace(session, config=config)
    checked, new, _, redo = check_drifts(trusted, trusted, fused, FusionParams())
    assert not checked.replaced and new is trusted and not redo
    (note,) = checked.notes
    assert note.endswith("kept as declared ([calibration] trust_declared = true)")


def test_the_run_replaces_it_and_reports_the_declared(declared) -> None:
    session, _ = declared
    output = run_pipeline(session, RunConfig())
    notes = [n for n in output.notes if n.startswith("A's declared drift_sigma 5.0000 m/s")]
    assert len(notes) == 1 and "used instead" in notes[0]
    quality = output.dr_quality["A"]
    assert quality.declared_drift_mps == 5.0  # the bracket says what was declared
    assert quality.drift_mps < 0.5
    assert output.dr_quality["B"].leader and not quality.leader
    lines = calibration_lines(output)
    assert (
        "  B: leader, dead reckoning not checked (the fusion takes its own fix) [0.0200]" in lines
    )
    (a_line,) = [line for line in lines if line.startswith("  A: dead reckoning drift")]
    assert a_line.startswith(f"  A: dead reckoning drift {quality.drift_mps:.4f} m/s [5.0000]")


def test_session_toml_reads_and_writes_trust_declared() -> None:
    read = parse_session_toml("[calibration]\ntrust_declared = true\n")
    assert read.config.trust_declared
    assert session_toml_table(read.config)["calibration"] == {"trust_declared": True}
    assert not parse_session_toml("").config.trust_declared


def test_a_leader_is_never_inflated_with_its_partners(declared, monkeypatch) -> None:
    """dr-faults: the leader B's ranges were inconsistent because its followers drifted,
    and B was "drifting more than declared, x2.1" beside its own 0.0001 m/s: the NIS
    rounds inflate followers only (the leader's fix observes its position)."""
    from coopproc.stages.fusion import calibration

    session, _ = declared
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    rounds: list[int] = []

    def nis(observations):  # the first fusion: both ends of A-B inconsistent
        rounds.append(1)
        return {"A": 9.0, "B": 9.0, "C": 1.0} if len(rounds) == 1 else {"A": 1.0, "B": 9.0}

    monkeypatch.setattr(calibration, "_platform_nis", nis)
    _, scale, _ = calibration._drift_scales(session, frame, FusionParams(state="position"), {})
    assert scale == {"A": 3.0}  # sqrt(9); B's 9 never counted
    assert len(rounds) == 2


def test_figures_the_data_cannot_give_say_what_is_missing() -> None:
    from coopproc.run.calibration_summary import _dr_figures
    from coopproc.stages.fusion.dr_quality import DeadReckoningQuality

    nan = float("nan")
    short = _dr_figures(DeadReckoningQuality(nan, nan, nan, 0.251), " [0.2510]")
    assert short == (
        "dead reckoning not measured (fewer than 3 windows of 10 s of fused solution) [0.2510]"
    )
    still = _dr_figures(DeadReckoningQuality(0.0047, nan, nan, 0.015), " [0.0150]")
    assert still == (
        "dead reckoning drift 0.0047 m/s [0.0150], heading drift and scale not measured "
        "(fewer than 12 windows of 10 s with 1 m of travel or more)"
    )
    assert "n/a" not in short + still


def test_the_check_holds_at_every_length(declared) -> None:
    """The estimate is the recording's first ten minutes' (CHECK_SPAN_S): a navigation
    that drifts far beyond its declared figure only after them (a heading error
    accumulated over a day) leaves the figure as declared, and their answer is the same
    whether the recording stops there or goes on."""
    from coopproc.run.declared import CHECK_SPAN_S, first_span

    session, fused = declared
    t0 = float(fused["A"].time_s[0])
    cut = first_span(fused, 60.0)
    assert all(float(t.time_s[-1]) <= t0 + 60.0 for t in cut.values())
    assert len(cut["A"]) < len(fused["A"]) and cut["A"].enu_m.shape[0] == len(cut["A"])
    assert first_span(fused, CHECK_SPAN_S)["A"] is fused["A"]  # 120 s: checked whole
    # A declares 5 m/s; its first 60 s alone still contradict that
    sixty = check_drifts(session, session, cut, FusionParams())[0]
    assert set(sixty.contradicted) == {"A"}
    # a "fused" solution that, after the checked span, runs away from A's navigation at
    # 1 m/s: were the whole recording checked, A's 5 m/s would no longer be contradicted
    dt = float(np.median(np.diff(fused["A"].time_s)))
    late = np.arange(1, int(2 * CHECK_SPAN_S / dt)) * dt + float(fused["A"].time_s[-1])
    longer = {}
    for p, traj in fused.items():
        t = np.concatenate([traj.time_s, late])
        enu = np.concatenate([traj.enu_m, np.repeat(traj.enu_m[-1:], late.shape[0], axis=0)])
        longer[p] = Trajectory(p, t, enu)
    nav = dict(session.nav)
    for p in nav:
        tn = np.concatenate([nav[p].time_s, late])
        en = np.concatenate([nav[p].enu_m, np.repeat(nav[p].enu_m[-1:], late.shape[0], axis=0)])
        away = np.clip(tn - t0 - CHECK_SPAN_S, 0.0, None) * 1.0  # 1 m/s after the checked span
        en[:, 0] += away * (p == "A")
        nav[p] = Trajectory(p, tn, en)
    long_session = dataclasses.replace(session, nav=nav)
    whole = check_drifts(long_session, long_session, longer, FusionParams())[0]
    assert set(whole.contradicted) == {"A"}  # judged on the first ten minutes: as before
