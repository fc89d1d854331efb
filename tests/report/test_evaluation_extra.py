"""evaluation.csv beyond evo's APE (report/evaluation_extra.py): coverage of the reference
span, along / cross-track errors of known offsets, intervals holding their statistics,
and ``report --evaluate`` showing them."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.report.evaluation import EVALUATION_COLUMNS, evaluation
from coopproc.report.evaluation_extra import EXTRA_COLUMNS, INTERVAL_STATS, coverage


def _rows(t: np.ndarray, method: str, xyz: np.ndarray, ref: np.ndarray | None) -> pd.DataFrame:
    h = np.full(t.size, np.nan) if ref is None else np.hypot(*(xyz - ref)[:, :2].T)
    return pd.DataFrame(
        {
            "time": t,
            "platform": "A",
            "method": method,
            "east": xyz[:, 0],
            "north": xyz[:, 1],
            "up": xyz[:, 2],
            "error_h": h,
        }
    )


def _track(n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """1 Hz, eastward at 1 m/s for 200 s, then northward (a corner)."""
    t = np.arange(float(n))
    east = np.minimum(t, 200.0)
    north = np.maximum(t - 200.0, 0.0)
    return t, np.column_stack([east, north, np.zeros(n)])


def test_along_and_cross_track_of_known_offsets() -> None:
    t, ref = _track()
    rng = np.random.default_rng(0)
    noise = 0.01 * rng.standard_normal((t.size, 3))
    # 0.3 m ahead and 0.2 m to the left of the direction of travel, 0.1 m up
    heading = np.where(t[:, None] < 200, [[1.0, 0.0]], [[0.0, 1.0]])
    left = np.column_stack([-heading[:, 1], heading[:, 0]])
    offset = 0.3 * heading + 0.2 * left
    est = ref + np.column_stack([offset, np.full(t.size, 0.1)]) + noise
    table = pd.concat([_rows(t, "reference", ref, None), _rows(t, "di", est, ref)])
    row = evaluation(table).iloc[0]
    assert list(evaluation(table).columns[-len(EXTRA_COLUMNS) :]) == list(EXTRA_COLUMNS)
    assert list(EVALUATION_COLUMNS[: -len(EXTRA_COLUMNS)])[-1] == "align_up"  # appended
    assert row["mean_along"] == pytest.approx(0.3, abs=0.01)
    assert row["mean_cross"] == pytest.approx(0.2, abs=0.01)
    assert row["rms_along"] == pytest.approx(0.3, abs=0.01)
    assert row["mean_up"] == pytest.approx(0.1, abs=0.01)
    assert row["coverage"] == 1.0
    for stat in INTERVAL_STATS:
        assert row[f"{stat}_lo"] <= row[stat] <= row[f"{stat}_hi"], stat


def test_coverage_counts_the_reference_span_positioned() -> None:
    t_ref = np.arange(0.0, 100.0, 0.1)  # a 10 Hz reference
    assert coverage(t_ref, np.arange(0.0, 100.0, 1.0)) == pytest.approx(1.0)  # 1 Hz: all
    # positioned for the first 60 s only: lost tracking the RMSE cannot see
    assert coverage(t_ref, np.arange(0.0, 60.0, 1.0)) == pytest.approx(0.6, abs=0.01)
    assert coverage(t_ref, np.empty(0)) == 0.0
    assert np.isnan(coverage(np.empty(0), t_ref))
    t, ref = _track()
    short = t < 300  # the method stops 100 s before the end
    table = pd.concat(
        [_rows(t, "reference", ref, None), _rows(t[short], "di", ref[short] + 0.05, ref[short])]
    )
    assert evaluation(table).iloc[0]["coverage"] == pytest.approx(0.75, abs=0.01)
