"""The observed fusion's IGG-III judgement carried onto a smoothed (DI) range set
(fusion/carried_weights.py): each DI range judged against the observed solution."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pandas as pd

from coopproc.estimation.robust import igg3_factor
from coopproc.stages.fusion.carried_weights import MIN_CARRIED, carried_factors


def _session(frame: pd.DataFrame) -> Any:
    return cast(Any, SimpleNamespace(ranges=SimpleNamespace(frame=frame)))


def test_a_di_range_is_judged_against_the_observed_solution() -> None:
    # observed ranges of A-B (listed B->A once: the pair is unordered) and A-C
    observed = pd.DataFrame(
        {
            "time": [1.0, 2.0, 3.0, 4.0, 1.0],
            "from": ["A", "B", "A", "A", "A"],
            "to": ["B", "A", "B", "B", "C"],
            "range": [10.5, 10.6, 10.0, 11.0, 5.0],
        }
    )
    # the observed fusion: residual 0.5 m at t=1 (s = 5: rejected), 0.4 at t=2 (s = 3.5),
    # full weight at t=3, rejected at t=4; scale 0.1 m per unit of s
    weights = pd.DataFrame(
        {
            "time": [1.0, 2.0, 3.0, 4.0, 1.0],
            "pair": pd.Categorical(["A-B", "A-B", "A-B", "A-B", "A-C"]),
            "innovation": [0.5, 0.35, 0.05, 0.8, 0.0],
            "standardized": [5.0, 3.5, 0.5, 8.0, 0.0],
            "gamma": [1e-30, float(igg3_factor(3.5, 3.0, 4.0)), 1.0, 1e-30, 1.0],
        }
    )
    di = pd.DataFrame(
        {
            "time": [1.0, 2.0, 3.0, 4.0, 1.0, 9.0],
            "from": ["A", "A", "A", "A", "A", "A"],
            "to": ["B", "B", "B", "B", "C", "B"],
            # t=1: DI pulled the range 0.45 m back (residual 0.05 m, s = 0.5: full weight);
            # t=2: 0.03 m back (s = 3.2); t=3: far off, but the observed range had full
            # weight; t=4: unchanged (still rejected); t=9: no observed counterpart
            "range": [10.05, 10.57, 12.0, 11.0, 5.0, 7.0],
        }
    )
    got = carried_factors(_session(observed), di, weights, 3.0, 4.0)
    expected = [1.0, float(igg3_factor(3.2, 3.0, 4.0)), 1.0, MIN_CARRIED, 1.0, 1.0]
    np.testing.assert_allclose(got, expected, rtol=1e-9)
    assert 0.3 < got[1] < 0.9  # 3.2 sigma: down-weighted, not rejected
