"""row_sigma: each output row's observed sigma, as a left merge on (time, pair) gives it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from coopproc.model import RangeTable
from coopproc.run.range_sets import row_sigma
from coopproc.sim import simulate
from coopproc.stages.ranging.table import observed_table


def _merged(session, table: pd.DataFrame) -> pd.Series:
    """The definition: the first observed row of the same time and pair (pandas merge)."""
    obs = session.ranges.frame[["time", "pair", "sigma"]]
    merged = table[["time", "pair"]].merge(
        obs.drop_duplicates(["time", "pair"]), on=["time", "pair"], how="left"
    )
    sigma = merged["sigma"].astype(float)
    if session.config.uwb_sigma_m is not None:
        sigma = sigma.fillna(session.config.uwb_sigma_m)
    return sigma.reset_index(drop=True)


@pytest.mark.parametrize("declared", [None, 0.2])
def test_row_sigma_is_the_first_observed_row_of_the_same_time_and_pair(declared) -> None:
    session = simulate("paper-experiment", seed=0, duration_s=30.0).session
    frame = session.ranges.frame.copy()
    rng = np.random.default_rng(3)
    frame["sigma"] = rng.uniform(0.05, 0.3, len(frame))
    frame.loc[frame.index[::7], "sigma"] = np.nan  # rows without a sigma
    # a repeated (time, pair) with another sigma: the first one counts
    twin = frame.iloc[[10, 20]].assign(sigma=[9.0, 8.0])
    frame = pd.concat([frame, twin]).sort_values("time", kind="stable").reset_index(drop=True)
    config = dataclasses.replace(session.config, uwb_sigma_m=declared)
    session = dataclasses.replace(session, ranges=RangeTable(frame), config=config)
    base = observed_table(session)
    table = pd.concat(
        [base, pd.DataFrame({"time": [1.0, base["time"][0]], "pair": [base["pair"][0], "X-Y"]})],
        ignore_index=True,
    )  # a time and a pair the session does not have
    got = row_sigma(session, table)
    want = _merged(session, table)
    assert got.to_numpy().tobytes() == want.to_numpy().tobytes()
    assert got.index.equals(want.index) and got.dtype == want.dtype
    assert (got == 9.0).sum() == 0 and (got == 8.0).sum() == 0  # the twins took the first's
    assert np.isnan(got.iloc[-1]) if declared is None else got.iloc[-1] == declared
