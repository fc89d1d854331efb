"""Invariants of every simulated session, for random scenarios, seeds and lengths."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from coopproc.model import pair_name
from coopproc.sim import SCENARIOS, simulate


@settings(max_examples=25, deadline=None)
@given(
    scenario=st.sampled_from(sorted(SCENARIOS)),
    seed=st.integers(0, 2**32 - 1),
    duration=st.floats(2.0, 150.0),
)
def test_any_session_is_consistent(scenario: str, seed: int, duration: float) -> None:
    kwargs = {"platforms": 3} if scenario == "large" else {}
    sim = simulate(scenario, seed=seed, duration_s=duration, **kwargs)
    session, truth = sim.session, sim.truth
    start = truth.params.start_tow_s
    ranges = session.ranges.frame
    assert (np.diff(ranges["time"].to_numpy()) >= 0).all()
    assert ranges["time"].between(start, start + duration + 1e-6).all()
    assert (ranges["range"] > 0).all()
    assert [pair_name(a, b) for a, b in zip(ranges["from"], ranges["to"], strict=True)] == list(
        ranges["pair"]
    )
    assert len(truth.distances) == len(ranges)
    np.testing.assert_allclose(
        ranges["range"].to_numpy() - truth.distances["distance"].to_numpy(),
        truth.distances["error"].to_numpy(),
        atol=1e-9,
    )
    faults = truth.nav_faults
    for pid, nav in session.nav.items():
        missing = faults[(faults["platform"] == pid) & (faults["fault"] == "nav_gap")]["value"]
        assert len(nav) == int(np.floor(duration * 10 + 1e-9)) + 1 - int(missing.sum())
        assert np.isfinite(nav.enu_m).all() and nav.sigma_enu_m is not None
        assert (np.diff(nav.time_s) > 0).all()
        ref = session.reference[pid]
        assert ref.quality is not None and set(np.unique(ref.quality)) <= {1, 2}
    events = truth.nlos_events
    assert (events["end"] >= events["start"]).all()
    # the truth lists only what the session holds: events with written epochs, gaps
    # that remove nav rows, outages without ranges
    assert (events["epochs"] > 0).all() and (events["realized_mean"] >= 0).all()
    assert (faults[faults["fault"] == "nav_gap"]["value"] > 0).all()
    t_rel = ranges["time"].to_numpy() - start
    for outage in truth.params.outages:
        assert outage.end_s <= duration
        assert not ((t_rel >= outage.start_s) & (t_rel <= outage.end_s)).any()
