"""NLOS detection scored against the reference: known answers by hand."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from coopproc.report.scores import (
    NLOS_SCORE_COLUMNS,
    _in_events,
    nlos_event_scores,
    nlos_scores,
    robust_sigma,
)


def _ranges() -> pd.DataFrame:
    bias = [0.0, 0.0, 0.5, 0.6, 0.55, 0.0, 0.0, 0.0, 0.5, 0.0]
    return pd.DataFrame(
        {
            "time": np.arange(10.0),
            "pair": "A-B",
            "observed": 10.0 + np.array(bias),
            "rn": 10.0,
            "di": 10.0,
            "reference": 10.0,
            "nlos_flag": 0,
            "nlos_estimate": 0.0,
        }
    )


EVENTS = pd.DataFrame(
    {
        "pair": ["A-B"],
        "method": ["di"],
        "start": [2.0],
        "end": [5.0],
        "epochs": [4],
        "estimate": [0.5],
    }
)


def test_scores_by_hand() -> None:
    # truth (e > 3 x 0.1): epochs 2, 3, 4, 8; di detects 2..5 -> tp 3, fp 1, fn 1
    s = nlos_scores(_ranges(), EVENTS, {"A-B": 0.1})
    assert tuple(s.columns) == NLOS_SCORE_COLUMNS
    di = s[s["method"] == "di"].iloc[0]
    assert (di["tp"], di["fp"], di["fn"], di["nlos_true"], di["detected"]) == (3, 1, 1, 4, 4)
    assert di["precision"] == pytest.approx(0.75)
    assert di["recall"] == pytest.approx(0.75)
    assert di["f1"] == pytest.approx(0.75)
    # bias over epochs 2..5 = (0.5 + 0.6 + 0.55 + 0) / 4 = 0.4125
    assert di["estimate_mae"] == pytest.approx(0.5 - 0.4125)
    rn = s[s["method"] == "rn"].iloc[0]
    assert (rn["tp"], rn["fp"], rn["fn"], rn["events"]) == (0, 0, 4, 0)
    assert math.isnan(rn["precision"]) and rn["recall"] == 0 and rn["f1"] == 0


def test_event_scores_signed_error() -> None:
    ev = nlos_event_scores(_ranges(), EVENTS)
    row = ev.iloc[0]
    assert row["epochs"] == 4
    assert row["reference_bias"] == pytest.approx(0.4125)
    assert row["error"] == pytest.approx(0.0875)


def test_missing_sigma_uses_mad_and_no_reference_scores_nothing() -> None:
    assert robust_sigma(np.array([1.0, 2.0, 3.0, 4.0, 100.0])) == pytest.approx(1.4826)
    ranges = _ranges()
    s = nlos_scores(ranges, EVENTS, {})
    # MAD of the residuals [0 x 6, 0.5, 0.6, 0.55, 0.5]: median 0, MAD 0 -> every bias > 0
    assert s.iloc[0]["sigma"] == pytest.approx(0.0)
    no_ref = nlos_scores(ranges.assign(reference=np.nan), EVENTS, {"A-B": 0.1})
    assert list(no_ref["epochs"]) == [0, 0]
    assert math.isnan(no_ref.iloc[1]["recall"])


def test_events_found_by_binary_search_are_the_epochs_between_start_and_end() -> None:
    rng = np.random.default_rng(2)
    t = np.sort(np.round(rng.uniform(0.0, 100.0, 500), 1))  # ties on the edges too
    t[-3:] = np.nan  # times sort NaN last
    starts = np.round(rng.uniform(-5.0, 100.0, 40), 1)
    ends = starts + np.round(rng.uniform(-2.0, 8.0, 40), 1)  # some end before they start
    starts[:3], ends[3:5] = [np.nan, -np.inf, 50.0], [np.nan, np.inf]
    expected = np.zeros(t.shape[0], dtype=bool)
    for start, end in zip(starts, ends, strict=True):
        expected |= (t >= start) & (t <= end)
    np.testing.assert_array_equal(_in_events(t, starts, ends), expected)
    assert expected.any() and not expected.all()
