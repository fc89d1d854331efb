"""The paper 000 ranging stage as the chain sees it: registry entry ``ranging``.

It produces the methods ``rn`` (RN-Based reference method) and ``di`` (DI-Based), needs
the cooperative solution with the observed ranges (the CP DI of eq. (1)), and reads its
parameters from ``[ranging]`` (:class:`coopproc.stages.ranging.config.RangingConfig`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.stages.base import RangeInput, RangeProduct, RangeStage
from coopproc.stages.ranging.config import RangingConfig
from coopproc.stages.ranging.stage import run_ranging

__all__ = ["STAGE", "ranging_stage"]


def _only(frame: pd.DataFrame, methods: tuple[str, ...]) -> pd.DataFrame:
    return frame[frame["method"].isin(methods)].reset_index(drop=True)


def ranging_stage(inp: RangeInput, params: RangingConfig, methods: tuple[str, ...]) -> RangeProduct:
    """Run :func:`run_ranging` and keep the requested methods."""
    if inp.cp is None:
        raise StageError("ranging: no cooperative solution (the chain must fuse 'observed')")
    out = run_ranging(inp.session, inp.cp, params, methods, inp.cp_left_out, inp.dr_states)
    table = out.ranges
    same = len(table) == len(inp.table) and np.array_equal(
        table["time"].to_numpy(), inp.table["time"].to_numpy()
    )
    if not same or not (table["pair"].to_numpy() == inp.table["pair"].to_numpy()).all():
        raise StageError("ranging: rows out of step with the session's range table")
    nlos = {}
    if "di" in methods:
        nlos["di"] = (
            table["nlos_flag"].to_numpy(dtype=np.int64),
            table["nlos_estimate"].to_numpy(dtype=np.float64),
        )
    if out.rn_nlos is not None:
        nlos["rn"] = out.rn_nlos
    fusion_values = {}
    if "di" in methods and params.di.fusion_input == "corrected":
        # the DI range set's fusion takes the observed ranges less the DI-Based NLOS
        # estimates, not the distance smoothed with the dead reckoning the fusion
        # carries itself (docs/methods-ranging.md#di-fusion-input)
        flag, estimate = nlos["di"]
        observed = table["observed"].to_numpy(dtype=np.float64)
        fusion_values["di"] = observed - np.where(flag == 1, estimate, 0.0)
    return RangeProduct(
        values={m: table[m].to_numpy(dtype=np.float64) for m in methods},
        nlos=nlos,
        nlos_events=_only(out.nlos_events, methods),
        nlos_estimates=_only(out.nlos_estimates, methods),
        di=out.di if "di" in methods else None,
        sigma=out.sigma,
        calibration={k: v for k, v in out.calibration.items() if k[1] in methods},
        outlier=table["outlier"].to_numpy(dtype=np.int64),
        fusion_values=fusion_values,
    )


STAGE = RangeStage(
    name="ranging",
    methods=("rn", "di"),
    params_type=RangingConfig,
    section="ranging",
    run=ranging_stage,
    help="paper 000: DI smoothing, distance filter, NLOS detection and estimation "
    "(rn = RN-Based reference method, di = DI-Based)",
    needs_cp=True,
    smoothed=("di",),  # DI smoothing; RN is the observed ranges less its estimates
    labels={"rn": ("RN", "RN-Based"), "di": ("DI", "DI-Based")},
    nlos_primary=("di",),  # the method of paper 000 (RN is its reference method)
)
