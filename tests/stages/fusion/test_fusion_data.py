"""The fusion's input preparation: range rows as codes, nav at the epochs, their sharing."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from coopproc.errors import StageError
from coopproc.model import Platform
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.shared.data import (
    clean_range_rows,
    clean_ranges,
    nav_at_epochs,
    platform_codes,
    shared_nav,
)
from tests.stages.fusion.test_fusion import make_session


@pytest.fixture(scope="module")
def small():
    session, _, _ = make_session(duration_s=60.0, followers=2)
    return session


def test_clean_ranges_drops_codes_and_sorts(small) -> None:
    platforms = {**small.platforms, "Z": Platform("Z", role="anchor", position_enu_m=(0, 0, 0))}
    platforms["Y"] = Platform("Y", role="anchor", position_enu_m=(5, 0, 0))
    session = dataclasses.replace(small, platforms=platforms)
    ranges = pd.DataFrame(
        {
            "time": [3.0, 1.0, np.nan, 2.0, 2.0, 0.5],
            "from": ["A", "B", "A", "Z", "C", "A"],
            "to": ["B", "C", "B", "Y", "Z", "C"],
            "range": [10.0, 11.0, 12.0, 5.0, 13.0, np.nan],
            "sigma": [0.2, np.nan, 0.2, 0.2, -1.0, 0.2],
        }
    )
    frame = clean_ranges(session, ranges, 0.1)
    # NaN time / range and anchor-anchor rows out, time order (stable), default sigma
    assert frame["time"].tolist() == [1.0, 2.0, 3.0]
    assert frame["from"].tolist() == ["B", "C", "A"]
    assert frame["to"].tolist() == ["C", "Z", "B"]
    assert np.allclose(frame["var"], [0.01, 0.01, 0.04])
    assert frame["from"].dtype == pd.DataFrame({"x": np.array(["A"], dtype=object)})["x"].dtype
    rows = clean_range_rows(session, ranges, 0.1)
    assert [rows.ids[c] for c in rows.to_code] == ["C", "Z", "B"]
    assert list(rows.id_column(rows.from_code)) == ["B", "C", "A"]


def test_clean_ranges_errors_name_the_row(small) -> None:
    ranges = pd.DataFrame(
        {"time": [1.0, 2.0, 3.0], "from": ["A", "A", "B"], "to": ["B", "Q", "B"], "range": 1.0}
    )
    with pytest.raises(StageError, match="platform 'Q' in column 'to'"):
        clean_ranges(small, ranges, 0.1)
    # a dropout row naming an unknown platform is dropped before the check
    dropout = ranges.assign(range=[1.0, np.nan, 1.0])
    with pytest.raises(StageError, match=r"from 'B' to itself at time 3\.0"):
        clean_ranges(small, dropout, 0.1)


def test_platform_codes_with_missing_and_absent_ids() -> None:
    ids = pd.Series(["B", None, "Q", "A", "B"], dtype="str")
    assert platform_codes(ids, ["A", "B"]).tolist() == [1, -1, -1, 0, 1]


def test_nav_at_epochs_is_the_stacked_interpolation(small) -> None:
    moving = list(small.moving_platforms())
    epochs = np.array([-1.0, 0.0, 0.05, 10.37, 59.99, 60.0, 70.0])
    want = np.stack([small.nav[p].interpolate(epochs) for p in moving])
    assert np.array_equal(nav_at_epochs(small, moving, epochs), want, equal_nan=True)


def test_shared_nav_gives_the_same_array_only_inside_and_for_the_same_epochs(small) -> None:
    moving = list(small.moving_platforms())
    epochs = np.linspace(1.0, 50.0, 200)
    assert nav_at_epochs(small, moving, epochs) is not nav_at_epochs(small, moving, epochs)
    with shared_nav():
        first = nav_at_epochs(small, moving, epochs)
        assert nav_at_epochs(small, moving, epochs.copy()) is first
        other = nav_at_epochs(small, moving, epochs + 0.01)
        assert other is not first
        assert nav_at_epochs(small, moving[:1], epochs + 0.01) is not other
    assert nav_at_epochs(small, moving, epochs) is not first


def test_fusions_sharing_the_nav_equal_fusions_alone(small) -> None:
    ranges = small.ranges.frame
    alone = fuse(small, ranges, FusionParams(self_calibrate=False))
    with shared_nav():
        fuse(small, ranges.assign(range=ranges["range"] + 0.5), FusionParams(self_calibrate=False))
        shared = fuse(small, ranges, FusionParams(self_calibrate=False))
    for pid, traj in alone.smoothed.items():
        assert np.array_equal(traj.enu_m, shared.smoothed[pid].enu_m)
        assert np.array_equal(alone.forward[pid].enu_m, shared.forward[pid].enu_m)
    pd.testing.assert_frame_equal(alone.observations, shared.observations)
