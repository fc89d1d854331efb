"""The fusion's IGG-III decisions scored against the reference (report/outlier_scores.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.report.outlier_scores import fusion_outlier_scores
from coopproc.report.scores import NLOS_SCORE_COLUMNS
from coopproc.stages.base import PositionProduct
from coopproc.stages.fusion.range_weights import range_weights_of


def _ranges() -> pd.DataFrame:
    # A-B errors against the reference (observed): 0, +0.5, -0.5, 0.05, no reference
    return pd.DataFrame(
        {
            "time": [1.0, 2.0, 3.0, 4.0, 5.0, 1.0, 2.0],
            "pair": ["A-B"] * 5 + ["A-C"] * 2,
            "observed": [10.0, 10.5, 9.5, 10.05, 10.0, 7.0, 7.0],
            "di": [10.0, 10.0, 10.0, 10.0, 10.0, 7.0, 7.0],
            "reference": [10.0, 10.0, 10.0, 10.0, np.nan, 7.0, 7.0],
        }
    )


def _weights() -> pd.DataFrame:
    frame = pd.DataFrame(
        {
            "time": [4.0, 1.0, 2.0, 3.0, 5.0, 2.0, 9.0, 1.0, 2.0],
            "pair": ["A-B"] * 5 + ["A-B", "A-B", "A-C", "A-C"],
            "method": ["observed"] * 5 + ["di", "observed", "observed", "observed"],
            # A-B observed: t4 rejected, t2 down-weighted, t3 full weight, t5 (no ref) rejected
            "gamma": [1e-30, 1.0, 0.2, 1.0, 1e-30, 0.5, 1e-30, 1.0, 1.0],
        }
    )
    frame["rejected"] = (frame["gamma"] <= 1e-30).astype(np.int64)
    return frame


def test_scores_two_sided_outliers_against_the_method_ranges() -> None:
    scores = fusion_outlier_scores(_ranges(), _weights(), {"A-B": 0.1}, ("observed", "di"))
    assert list(scores.columns) == [*NLOS_SCORE_COLUMNS, "rejected_tp"]
    assert list(scores["method"]) == ["fusion:observed", "fusion:di"] * 2
    ab = scores.iloc[0]
    # scored: t1..t4 (t5 has no reference, t9 no range row); truth |e| > 0.3: t2, t3
    assert ab["epochs"] == 4 and ab["nlos_true"] == 2
    # down-weighted: t2 (a true one), t4 (e = 0.05, false): tp 1, fp 1, fn 1 (t3)
    assert (ab["detected"], ab["tp"], ab["fp"], ab["fn"]) == (2, 1, 1, 1)
    assert ab["precision"] == pytest.approx(0.5) and ab["recall"] == pytest.approx(0.5)
    assert ab["f1"] == pytest.approx(0.5)
    assert ab["events"] == 1 and ab["rejected_tp"] == 0  # t4 rejected, and it is clean
    assert ab["sigma"] == pytest.approx(0.1)
    assert np.isnan(ab["estimate_mae"])
    # di's ranges are exact: its one down-weighted range (t2) is a false alarm
    di = scores.iloc[1]
    assert (di["epochs"], di["nlos_true"], di["detected"], di["fp"]) == (1, 0, 1, 1)
    assert di["precision"] == 0.0
    assert np.isnan(di["recall"])
    # A-C: no declared sigma, robust sigma of observed - reference (0): nothing is > 0
    ac = scores.iloc[2]
    assert (ac["epochs"], ac["nlos_true"], ac["detected"]) == (2, 0, 0)


def test_no_weights_no_rows() -> None:
    assert len(fusion_outlier_scores(_ranges(), None, {})) == 0


def test_range_weights_of_names_sorts_and_flags() -> None:
    part = pd.DataFrame(
        {
            "time": [2.0, 1.0],
            "pair": ["B-C", "A-B"],
            "innovation": [0.1, 5.0],
            "standardized": [0.5, 25.0],
            "gamma": [1.0, 1e-30],
        }
    )
    products = {
        "observed": PositionProduct(positions={}, range_weights=part),
        "di": PositionProduct(positions={}, range_weights=part.iloc[:1]),
        "lsq": PositionProduct(positions={}),
    }
    table = range_weights_of(products)
    assert table is not None
    assert list(table.columns) == [
        "time", "pair", "method", "innovation", "standardized", "gamma", "rejected",
    ]  # fmt: skip
    assert list(zip(table["pair"], table["method"], strict=True)) == [
        ("A-B", "observed"), ("B-C", "di"), ("B-C", "observed"),
    ]  # fmt: skip
    assert list(table["rejected"]) == [1, 0, 0]
    assert range_weights_of({"lsq": PositionProduct(positions={})}) is None
