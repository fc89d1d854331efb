"""report.panels.groups: the rows per value, as slices of the table when its rows come
value by value (positions.csv's order), else as pandas groups; the same rows either way."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from coopproc.report.panels import groups


def _by_groupby(frame: pd.DataFrame, column: str) -> dict[str, pd.DataFrame]:
    return {str(k): g for k, g in frame.groupby(column, sort=False, observed=True)}


@pytest.mark.parametrize("categorical", [False, True])
def test_rows_together_are_views_with_the_groupby_rows(categorical: bool) -> None:
    keys = ["B", "B", "A", "C", "C", "C"]
    frame = pd.DataFrame({"p": keys, "x": np.arange(6.0)})
    if categorical:
        frame["p"] = pd.Categorical(keys, categories=["A", "B", "C", "unused"])
    got = groups(frame, "p")
    want = _by_groupby(frame, "p")
    assert list(got) == list(want) == ["B", "A", "C"]
    for key in want:
        pd.testing.assert_frame_equal(got[key], want[key])
    assert np.shares_memory(got["C"]["x"].to_numpy(), frame["x"].to_numpy())


def test_interleaved_or_missing_values_fall_back_to_groupby() -> None:
    frame = pd.DataFrame({"p": ["B", "A", "B", None], "x": np.arange(4.0)})
    got = groups(frame, "p")
    assert {k: v.index.tolist() for k, v in got.items()} == {"B": [0, 2], "A": [1]}
    assert groups(frame.iloc[:0], "p") == {}


def test_categorical_runs_are_grouped_from_their_codes_as_groupby_groups_them() -> None:
    names = ["di", "nav", "observed", "rn"]
    cases = {
        "runs": [2, 2, 0, 0, 0, 3, 1, 1],  # each value together, not in category order
        "split": [2, 2, 0, 2, 1],  # observed in two runs: the general path
        "missing": [2, -1, -1, 0],  # a missing value: the general path
    }
    for name, codes in cases.items():
        frame = pd.DataFrame(
            {
                "method": pd.Categorical.from_codes(codes, categories=names),
                "x": np.arange(len(codes), dtype=float),
            }
        )
        got = groups(frame, "method")
        want = {str(k): g for k, g in frame.groupby("method", sort=False, observed=True)}
        assert list(got) == list(want), name
        for key in want:
            pd.testing.assert_frame_equal(got[key], want[key])
    runs = pd.DataFrame({"method": pd.Categorical.from_codes(cases["runs"], names), "x": 1.0})
    piece = groups(runs, "method")["observed"]
    assert np.shares_memory(piece["x"].to_numpy(), runs["x"].to_numpy())  # a slice, no copy
