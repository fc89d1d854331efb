"""A running-median range processor: method ``median``, a baseline with no model at all.

Each pair's observed ranges, by time, replaced by the median of a centred window of
``window`` ranges (shorter at the ends of the series). It removes isolated outliers and
halves the white noise of a straight segment, but follows a lasting NLOS bias as it is:
the baseline that shows what DI-Based and RN-Based add. It is also the worked example
of docs/extending.md: one module, one line in :mod:`coopproc.stages.registry`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.stages.base import RangeInput, RangeProduct, RangeStage

__all__ = ["STAGE", "MedianParams", "median_ranges"]


@dataclass(frozen=True)
class MedianParams:
    """``[median]``: the running-median range processor."""

    window: int = field(
        default=5, metadata={"help": "ranges in the centred window (odd, at least 3)"}
    )

    def __post_init__(self) -> None:
        if self.window < 3 or self.window % 2 == 0:
            raise ValueError(f"window = {self.window}, expected an odd number >= 3")


def median_ranges(inp: RangeInput, params: MedianParams, methods: tuple[str, ...]) -> RangeProduct:
    """Each pair's running median of the observed ranges, aligned with ``inp.table``."""
    observed = inp.table["observed"]
    median = observed.groupby(inp.table["pair"], sort=False).transform(
        lambda s: s.rolling(params.window, center=True, min_periods=1).median()
    )
    return RangeProduct(values={"median": pd.to_numeric(median).to_numpy(dtype=np.float64)})


STAGE = RangeStage(
    name="median",
    methods=("median",),
    params_type=MedianParams,
    section="median",
    run=median_ranges,
    help="running median of each pair's observed ranges (a model-free baseline)",
    smoothed=("median",),
)
