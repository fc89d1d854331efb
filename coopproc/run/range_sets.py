"""The range sets a run's position estimators take (:mod:`coopproc.run.pipeline`): one
processed method's distances as a range table, and the UWB sigma of each row."""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, Session, pair_members

__all__ = ["ranges_for", "row_sigma"]


def ranges_for(base: pd.DataFrame, values: FloatArray, sigma: pd.Series) -> pd.DataFrame:
    """One processed method's distances in the shape the position estimators take."""
    codes, pairs = pd.factorize(base["pair"])
    members = [pair_members(str(p)) for p in pairs]
    # each id column as a take of the few distinct ids (a day: 3.8 M rows; making the
    # column's strings from a Python string per row was 1 s of each range set, issue 11)
    first, second = ([m[end] for m in members] for end in (0, 1))
    out = pd.DataFrame(
        {
            "time": base["time"].to_numpy(),
            "from": pd.array(first, dtype="str").take(codes),
            "to": pd.array(second, dtype="str").take(codes),
            "range": values,
            "sigma": sigma.to_numpy(),
        }
    )
    return out[np.isfinite(out["range"].to_numpy())].reset_index(drop=True)


def row_sigma(session: Session, table: pd.DataFrame) -> pd.Series:
    """The UWB sigma of each row of the output range table (for the processed fusions).

    Processed ranges keep the sigma of the observed range they came from (the ranging
    stage reduces the noise, but weighting them as the raw ranges keeps the fusion
    conservative); rows without one get the session's ``[uwb] sigma`` or NaN (the fusion
    default). A row's observed range is the session's first row of the same pair and time
    (NaN times match each other, as in a pandas merge); it is found per pair by a search in
    that pair's times, not by merging on the (time, pair) strings of every row (about 5 s
    at a day of 10 platforms, issue 11).
    """
    frame = session.ranges.frame
    times = frame["time"].to_numpy(np.float64)
    sigma_of = frame["sigma"].to_numpy(np.float64)
    wanted = table["time"].to_numpy(np.float64)
    out = np.full(wanted.shape[0], np.nan)
    codes, names = pd.factorize(table["pair"])  # a missing pair: -1, no sigma
    order = np.argsort(codes, kind="stable")
    bounds = np.searchsorted(codes[order], np.arange(len(names) + 1))
    index = session.ranges.pair_index
    for code, name in enumerate(names):
        rows = index.get(str(name))
        if rows is None or rows.shape[0] == 0:
            continue
        at = order[bounds[code] : bounds[code + 1]]
        by_time = rows[np.argsort(times[rows], kind="stable")]  # NaN last, file order kept
        sorted_times = times[by_time]
        first = np.searchsorted(sorted_times, wanted[at], side="left")  # the first equal one
        inside = np.minimum(first, sorted_times.shape[0] - 1)
        found = sorted_times[inside]
        hit = (first < sorted_times.shape[0]) & (
            (found == wanted[at]) | (np.isnan(found) & np.isnan(wanted[at]))
        )
        out[at[hit]] = sigma_of[by_time[inside[hit]]]
    sigma = pd.Series(out)
    if session.config.uwb_sigma_m is not None:
        sigma = sigma.fillna(session.config.uwb_sigma_m)
    return sigma
