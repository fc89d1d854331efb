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
the fusion has already made: no pass of its own.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from coopproc.names import RANGE_WEIGHTS_COLUMNS
from coopproc.stages.base import PositionProduct
from coopproc.stages.filters import GAMMA_REJECT
from coopproc.stages.fusion.data import pair_names
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
            "pair": pair_names(observations["from"], observations["to"]),
            "innovation": decisions.residual_m,
            "standardized": decisions.standardized,
            "gamma": decisions.gamma,
        },
        copy=False,
    )


def rejected(gamma: np.ndarray) -> np.ndarray:
    """1 where the factor rejects the range (IGG-III beyond k1: 1e-30), else 0 (int64)."""
    return (np.asarray(gamma, dtype=np.float64) <= GAMMA_REJECT).astype(np.int64)


def range_weights_of(products: Mapping[str, PositionProduct]) -> pd.DataFrame | None:
    """range_weights.csv: every position method's range weights (its method column the
    method's name), by pair, method and time; None when no method has them."""
    parts = [
        product.range_weights.assign(method=method)
        for method, product in products.items()
        if product.range_weights is not None and len(product.range_weights)
    ]
    if not parts:
        return None
    frame = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
    del parts
    frame = frame.sort_values(["pair", "method", "time"], kind="stable", ignore_index=True)
    frame["rejected"] = rejected(frame["gamma"].to_numpy())
    return frame[list(RANGE_WEIGHTS_COLUMNS)]
