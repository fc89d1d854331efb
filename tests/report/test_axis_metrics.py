"""Table 3 per axis (coopproc.report.axis_metrics, `coopproc report --axes`): per-axis
position RMS/max and velocity/attitude RMS against the reference rows."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.model import STATES_COLUMNS
from coopproc.report.axis_metrics import AXIS_METRICS_COLUMNS, axis_metrics
from coopproc.report.formats import format_tables
from coopproc.report.run_tables import RunTables


def _positions() -> pd.DataFrame:
    t = np.arange(0.0, 10.0, 1.0)
    ref = pd.DataFrame(
        {"time": t, "platform": "A", "method": "reference", "east": t, "north": 2 * t, "up": 1.0}
    )
    ref["error_h"] = np.nan
    # ins: east +0.1 always, north alternating +-0.2, up -0.3 at one epoch only
    tm = t[1:-1] + 0.5  # between reference epochs: interpolated truth
    ins = pd.DataFrame(
        {
            "time": tm,
            "platform": "A",
            "method": "ins",
            "east": tm + 0.1,
            "north": 2 * tm + np.where(np.arange(tm.size) % 2, 0.2, -0.2),
            "up": 1.0 + np.where(np.arange(tm.size) == 3, -0.3, 0.0),
        }
    )
    ins["error_h"] = np.hypot(0.1, 0.2)
    return pd.concat([ref, ins], ignore_index=True)


def _states() -> pd.DataFrame:
    t = np.arange(0.0, 10.0, 1.0)
    n = t.size
    ref = pd.DataFrame({"time": t, "platform": "A", "method": "reference"})
    ins = pd.DataFrame({"time": t, "platform": "A", "method": "ins"})
    for c in STATES_COLUMNS[3:]:
        ref[c] = np.nan
        ins[c] = np.nan
    ref["vel_east"], ins["vel_east"] = 1.0, 1.03
    ref["yaw"] = np.where(t < 5, 359.0, 1.0)  # the heading wraps through north
    ins["yaw"] = np.where(t < 5, 1.0, 359.0)  # 2 deg off either way, not 358
    ins["roll"] = 0.5  # the reference has no roll: no statistic
    ref["vel_north"] = np.linspace(0, 1, n)
    ins["vel_north"] = np.linspace(0, 1, n)
    return pd.concat([ref, ins], ignore_index=True)[list(STATES_COLUMNS)]


def test_per_axis_position_velocity_attitude() -> None:
    table = axis_metrics(_positions(), _states())
    assert list(table.columns) == list(AXIS_METRICS_COLUMNS)
    row = table.set_index("method").loc["ins"]
    assert row["rms_east"] == pytest.approx(0.1)
    assert row["max_east"] == pytest.approx(0.1)
    assert row["rms_north"] == pytest.approx(0.2)
    assert row["rms_up"] == pytest.approx(0.3 / np.sqrt(8))
    assert row["max_up"] == pytest.approx(0.3)
    assert row["rms_vel_east"] == pytest.approx(0.03)
    assert row["rms_vel_north"] == pytest.approx(0.0, abs=1e-12)
    assert np.isnan(row["rms_vel_up"]) and np.isnan(row["rms_roll"])
    assert row["rms_yaw"] == pytest.approx(2.0)
    assert row["n"] == 8


def test_without_states_only_positions() -> None:
    table = axis_metrics(_positions())
    row = table.set_index("method").loc["ins"]
    assert row["rms_east"] == pytest.approx(0.1)
    assert np.isnan(row["rms_vel_east"]) and np.isnan(row["rms_yaw"])


def test_report_axes_table() -> None:
    positions = _positions()
    empty = pd.DataFrame()
    run = RunTables(
        ranges=empty,
        di=empty,
        nlos_events=empty,
        nlos_estimates=empty,
        positions=positions,
        metrics=pd.DataFrame(columns=["pair", "method", "max", "mean", "rmse", "n"]),
        position_metrics=pd.DataFrame(columns=["platform", "method", "max", "rmse", "n"]),
        states=_states(),
        info={"methods": {"positions": ["ins"]}},
    )
    text = format_tables(run, "csv", axes=True)
    assert "# Table 3 per axis" in text
    block = text.split("# Table 3 per axis")[1]
    header = block.splitlines()[1].split(",")
    assert "rms_up" in header and "rms_yaw" in header
    assert "rms_roll" not in header  # no reference roll anywhere: the column is left out
    assert "Table 3 per axis" not in format_tables(run, "csv")


def test_nothing_across_reference_gaps() -> None:
    """The reference rows drop 5 s (epochs its Q filter refused): a method's epochs in
    that gap have no error, though the straight line across it would give one."""
    t = np.concatenate([np.arange(0.0, 10.0, 0.5), np.arange(15.0, 25.0, 0.5)])
    ref = pd.DataFrame({"time": t, "platform": "A", "method": "reference"})
    ref["east"], ref["north"], ref["up"] = np.where(t < 12, 0.0, 10.0), 0.0, 0.0
    tm = np.arange(0.25, 25.0, 0.5)
    own = pd.DataFrame({"time": tm, "platform": "A", "method": "lsq", "east": 0.1, "north": 0.0})
    own.loc[tm > 12, "east"] = 10.1
    own["up"], own["error_h"] = 0.0, 0.1
    row = axis_metrics(pd.concat([ref, own], ignore_index=True)).iloc[0]
    assert row["rms_east"] == pytest.approx(0.1)
    assert row["max_east"] == pytest.approx(0.1)


def test_row_order_and_text_storage_do_not_change_the_table() -> None:
    """Rows grouped by integer codes: shuffled rows (each method's own time order lost),
    categorical text columns and a second platform without reference give the same rows."""
    one = _positions()
    other = one[one["method"] == "ins"].assign(platform="B")  # no reference rows
    table = pd.concat([one, other], ignore_index=True)
    expected = axis_metrics(table, _states())
    assert expected["platform"].tolist() == ["A", "B"]
    assert expected.iloc[1]["n"] == 8 and np.isnan(expected.iloc[1]["rms_east"])
    shuffled = table.sample(frac=1.0, random_state=7).reset_index(drop=True)
    coded = table.astype({"platform": "category", "method": "category"})
    for variant in (shuffled, coded):
        pd.testing.assert_frame_equal(axis_metrics(variant, _states()), expected, check_exact=True)
