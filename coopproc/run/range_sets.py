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
    members = np.array([pair_members(str(p)) for p in pairs], dtype=object).reshape(-1, 2)
    out = pd.DataFrame(
        {
            "time": base["time"].to_numpy(),
            "from": members[codes, 0],
            "to": members[codes, 1],
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
    default).
    """
    obs = session.ranges.frame[["time", "pair", "sigma"]]
    merged = table[["time", "pair"]].merge(
        obs.drop_duplicates(["time", "pair"]), on=["time", "pair"], how="left"
    )
    sigma = merged["sigma"].astype(float)
    if session.config.uwb_sigma_m is not None:
        sigma = sigma.fillna(session.config.uwb_sigma_m)
    return sigma.reset_index(drop=True)
