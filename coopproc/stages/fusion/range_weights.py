"""``range_weights.csv``: the cooperative fusion's own outlier decisions (issue 30 item 7).

The ranging stage's DI and RN look for NLOS, a range that reads long for seconds; a single
range that is metres off (a multipath spike, a wrong reply) is an outlier, which the
fusion handles: paper 002's IGG-III factor (eq. (18)-(20)) gives every range a weight
gamma between 1 (full weight) and 0 (rejected, beyond ``[fusion] k1``). On real data most
single-epoch errors are of that kind, so what the fusion did with them is shown per range
and fusion method, and scored against the reference like NLOS
(:mod:`coopproc.report.outlier_scores`, ``nlos_scores.csv`` methods ``fusion:<method>``).

The factors are those of the pass whose solution positions.csv reports: the self-
calibration fuses a range set several times (drift rounds, the final fusion with the
calibrated sigmas) and the robust smoother refits the factors against the smoothed
solution (:mod:`~coopproc.stages.fusion.robust_refit`); only the returned fusion's last
factors are kept (:class:`~coopproc.stages.fusion.fuse.RangeDecisions`), so a range's row
says with which weight it entered the reported solution. Building the table reads arrays
the fusion has already made: no pass of its own. Memory (issue 11): a row holds four
floats and one-byte pair, method and flag codes (categoricals), 35 bytes; at a day of
10 platforms, 3.8 M ranges, about 130 MB per fusion method.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from coopproc.estimation.robust import GAMMA_REJECT
from coopproc.names import RANGE_WEIGHTS_COLUMNS, pair_name
from coopproc.stages.base import PositionProduct
from coopproc.stages.fusion.fuse import FusionOutput

__all__ = ["range_weights_frame", "range_weights_of", "rejected"]


def range_weights_frame(ranges: pd.DataFrame, fused: FusionOutput) -> pd.DataFrame | None:
    """One fusion's rows of range_weights.csv (no ``method``, no ``rejected``): each range
    it used at the range's own time (``ranges``: the table given to the fusion), in the
    fusion's row order; None without decisions (a discarded fusion)."""
    decisions = fused.decisions
    if decisions is None:
        return None
    time = ranges["time"].to_numpy(np.float64)[decisions.source]
    observations = fused.observations
    return pd.DataFrame(
        {
            "time": time,
            "pair": _pair_column(observations["from"], observations["to"]),
            "innovation": decisions.residual_m,
            "standardized": decisions.standardized,
            "gamma": decisions.gamma,
        },
        copy=False,
    )


def _pair_column(first: pd.Series, second: pd.Series) -> pd.Categorical[str]:
    """The pair names of two id columns as a categorical, its categories in name order:
    each column factorized, each distinct (first, second) combination named once."""
    code_a, uniq_a = pd.factorize(first, use_na_sentinel=False)
    code_b, uniq_b = pd.factorize(second, use_na_sentinel=False)
    width = max(len(uniq_b), 1)
    combos, inverse = np.unique(code_a.astype(np.int64) * width + code_b, return_inverse=True)
    names = [pair_name(str(uniq_a[k // width]), str(uniq_b[k % width])) for k in combos]
    categories = sorted(set(names))
    lut = np.array([categories.index(n) for n in names], dtype=np.int64)
    return pd.Categorical.from_codes(lut[inverse.reshape(-1)], categories=pd.Index(categories))


def rejected(gamma: np.ndarray) -> np.ndarray:
    """1 where the factor rejects the range (IGG-III beyond k1: 1e-30), else 0 (int8)."""
    return (np.asarray(gamma, dtype=np.float64) <= GAMMA_REJECT).astype(np.int8)


def range_weights_of(products: Mapping[str, PositionProduct]) -> pd.DataFrame | None:
    """range_weights.csv: every position method's range weights (its method column the
    method's name), by pair, method and time; None when no method has them."""
    weighed = {
        method: product.range_weights
        for method, product in products.items()
        if product.range_weights is not None and len(product.range_weights)
    }
    if not weighed:
        return None
    # one set of categories for every part (name order), so that the codes concatenate
    pairs = sorted(
        {str(p) for f in weighed.values() for p in f["pair"].astype("category").cat.categories}
    )
    methods = sorted(weighed)
    parts = [
        frame.assign(
            pair=pd.Categorical(frame["pair"], categories=pairs),
            method=pd.Categorical.from_codes(
                np.full(len(frame), methods.index(method), dtype=np.int8),
                categories=pd.Index(methods),
            ),
        )
        for method, frame in weighed.items()
    ]
    del weighed
    frame = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
    del parts
    # categories in name order: the sort is by pair, method (names), then time
    frame = frame.sort_values(["pair", "method", "time"], kind="stable", ignore_index=True)
    frame["rejected"] = rejected(frame["gamma"].to_numpy())
    return frame[list(RANGE_WEIGHTS_COLUMNS)]
