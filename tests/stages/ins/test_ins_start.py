"""The start-up of the INS of a platform without navigation (issue 31 part 3;
docs/methods-ins.md, "Start"): refused with the reason and the data that would give one;
a heading nothing gives is searched, and a search that fits no candidate says so."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from coopproc.errors import StageError
from coopproc.model import RangeTable
from coopproc.sim.engine import simulate
from coopproc.stages.ins.ins_setup import ins_start
from coopproc.stages.ins.ins_stage import InsParams, _run_platform


@pytest.fixture(scope="module")
def sim():  # type: ignore[no-untyped-def]
    return simulate("quadrotor", seed=0, duration_s=40.0, platforms=7)


def test_start_refused_without_ranges_or_navigation(sim) -> None:  # type: ignore[no-untyped-def]
    s = sim.session
    frame = s.ranges.frame
    one = frame[(frame["from"] == "ifo001") | (frame["to"] == "ifo001")].iloc[:1]
    bare = dataclasses.replace(s, ranges=RangeTable(one, source="test"))
    with pytest.raises(StageError) as err:
        ins_start(bare, s.imu["ifo001"], one, level_sigma_deg=2.0, heading_sigma_deg=10.0)
    msg = str(err.value)
    assert msg.startswith("INS of ifo001: no start position")
    assert "ranges to anchors, at least 2 in all" in msg and "nav_<ID>.csv" in msg


def test_heading_searched_and_the_misfit_said(sim) -> None:  # type: ignore[no-untyped-def]
    """The drone's heading is searched (its course is not its heading); with ranges that
    deny every candidate (each range 1.5 m long on a third of them) the note warns."""
    s = sim.session
    frame = s.ranges.frame
    start = ins_start(s, s.imu["ifo001"], frame, level_sigma_deg=2.0, heading_sigma_deg=10.0)
    assert start.search and "aligned in motion" in start.how
    params = InsParams(search_window_s=20.0)
    res, note = _run_platform(s, "ifo001", frame, params, nhc=False, uwb=True)
    assert "heading by coarse search over 12 headings" in note and "warning" not in note
    truth = sim.truth.trajectories["ifo001"]
    true_yaw = np.radians(90.0 - truth.heading_deg[0])
    found = np.radians(res.smoothed.att_deg[0, 2])
    assert abs(np.angle(np.exp(1j * (found - true_yaw)))) < np.radians(5.0)
    bad = frame.copy()
    bad.loc[bad.index[::3], "range"] += 1.5
    _, note = _run_platform(s, "ifo001", bad, params, nhc=False, uwb=True)
    assert "warning: no candidate fits its ranges" in note
    assert "a navigation file with a heading, a static start of 5 s" in note
