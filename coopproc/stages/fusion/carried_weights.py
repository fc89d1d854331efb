"""The observed fusion's robust decisions carried into a smoothed range set's fusion.

DI-Based (paper 000 eq. (1)-(6)) smooths each range with the dead reckoning: a range that
reads long for a few epochs is pulled toward the CP prediction, so the excess that the
observed fusion's IGG-III test (paper 002 eq. (18)-(20)) saw and down-weighted is spread
over seconds of DI ranges, each too small for the DI fusion's own test. Those DI ranges
then enter with full weight (TIERS: the observed fusion down-weights 46 of tb3's ranges, 25
of them on tb3-tb4, and the DI fusion none; tb3-tb4's DI ranges there are 0.46 m off on
average), and the DI-fused error exceeds the observed-fused one.

So each DI range is judged again by the observed fusion, against the solution and with the
scale that fusion used (no figure of its own): the observed range ``L_o`` of the same pair
and time had the residual ``v_o`` (range_weights.csv ``innovation``: against the smoothed
solution with the robust smoother, else at the prior) and the standardized value ``s_o =
v_o / (sigma MAD-sigma)``; the DI range ``L_d`` has the residual ``v_d = v_o - (L_o - L_d)``
against the same positions (a platform range bias the fusion corrected cancels), so its
standardized value is ``s_d = v_d s_o / v_o`` and its carried factor the IGG-III factor of
``s_d`` (eq. (18), the fusion's k0, k1). A DI range whose raw counterpart the observed
fusion took at full weight carries 1 (and one DI corrected back to the solution, as DI's
NLOS estimate does, carries 1 again: the judgement is on the DI value, not a copy of the
observed factor). The DI fusion weighs each range with its sigma over the square root of
the carried factor (a factor gamma is a variance R / gamma, eq. (19)), after its own
per-pair sigmas; its own IGG-III test then runs as before.

``[fusion] carry_weights`` (off by default); only a range set its producer smooths
(``PositionInput.smoothed``: DI) carries them: RN-Based leaves its unflagged ranges raw,
and its own fusion's test sees them. Why it is off: measured (DI-fused / observed-fused,
worst platform, with the DI fusion on the observed DR noise factor) TIERS 1.115 -> 1.108,
MiLUV 1.092 -> 1.096, paper-experiment seed 2 at 15 min 1.116 -> 1.123, seed 1 1.134 ->
1.134: within noise. The observed solution itself follows a sustained NLOS run (TIERS
tb3-tb4: its smoothed distance reads 0.5 m long there), so the DI ranges, smoothed toward
the same run, look consistent with it: the judgement cannot see what both share.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.estimation.robust import GAMMA_REJECT, igg3_factor
from coopproc.model import FloatArray, Session
from coopproc.names import pair_name

__all__ = ["MIN_CARRIED", "carried_factors"]

#: The smallest carried factor: a rejected range's sigma grows 1000-fold (weight 1e-6),
#: so it stays a row of the fusion (range_weights.csv lists it) without a 1e15 sigma
MIN_CARRIED = 1e-6


def _pair_names(first: pd.Series, second: pd.Series) -> np.ndarray:
    code_a, uniq_a = pd.factorize(first, use_na_sentinel=False)
    code_b, uniq_b = pd.factorize(second, use_na_sentinel=False)
    width = max(len(uniq_b), 1)
    combos, inverse = np.unique(code_a.astype(np.int64) * width + code_b, return_inverse=True)
    names = np.array(
        [pair_name(str(uniq_a[k // width]), str(uniq_b[k % width])) for k in combos], dtype=object
    )
    return names[inverse.reshape(-1)]


def _keyed(time: FloatArray, pair: np.ndarray, value: FloatArray, name: str) -> pd.DataFrame:
    frame = pd.DataFrame({"time": time, "pair": pair, name: value})
    return frame.drop_duplicates(["time", "pair"], keep="first")


def carried_factors(
    session: Session, ranges: pd.DataFrame, weights: pd.DataFrame, k0: float, k1: float
) -> FloatArray:
    """Each row of ``ranges`` (time, from, to, range: a smoothed set) its carried factor
    in [MIN_CARRIED, 1] (module doc); ``weights``: the observed fusion's rows of
    range_weights.csv (time, pair, innovation, standardized, gamma). A row without an
    observed counterpart judged by it carries 1."""
    observed = session.ranges.frame
    raw = _keyed(
        observed["time"].to_numpy(np.float64),
        _pair_names(observed["from"], observed["to"]),
        observed["range"].to_numpy(np.float64),
        "observed",
    )
    judged = weights.loc[
        weights["gamma"].to_numpy(np.float64) < 1.0, ["time", "pair", "innovation", "standardized"]
    ]
    judged = judged.assign(pair=judged["pair"].astype(str).to_numpy(object))
    judged = judged.drop_duplicates(["time", "pair"], keep="first").merge(
        raw, on=["time", "pair"], how="inner"
    )
    rows = pd.DataFrame(
        {
            "time": ranges["time"].to_numpy(np.float64),
            "pair": _pair_names(ranges["from"], ranges["to"]),
            "smoothed": ranges["range"].to_numpy(np.float64),
        }
    )
    at = rows.merge(judged, on=["time", "pair"], how="left")  # one row per row of ranges
    v_o = at["innovation"].to_numpy(np.float64)
    s_o = at["standardized"].to_numpy(np.float64)
    v_d = v_o - (at["observed"].to_numpy(np.float64) - at["smoothed"].to_numpy(np.float64))
    usable = np.isfinite(v_d) & np.isfinite(s_o) & (np.abs(v_o) > 0)
    factor = np.ones(rows.shape[0])
    s_d = v_d[usable] * s_o[usable] / v_o[usable]
    factor[usable] = np.maximum(igg3_factor(s_d, k0, k1), MIN_CARRIED)
    assert GAMMA_REJECT < MIN_CARRIED
    return factor
