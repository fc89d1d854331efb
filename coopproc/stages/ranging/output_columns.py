"""The ranging stage's two tables (ranges and di), written pair by pair.

:class:`OutputColumns` preallocates every column of both tables for all the pairs' rows
and takes each pair's values as it is processed, so the stage lets go of a pair's inputs
once its rows are written (issue 11); :func:`compensated` is the RN-Based output.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import DI_COLUMNS, RANGES_OUT_COLUMNS, FloatArray
from coopproc.stages.ranging.di import SmoothedDI
from coopproc.stages.ranging.nlos import DistanceFilterOutput
from coopproc.stages.ranging.pair import PairInputs

__all__ = ["OutputColumns", "compensated"]


class OutputColumns:
    """ranges (RANGES_OUT_COLUMNS) and di (DI_COLUMNS) of every pair, in pair order, written
    pair by pair into preallocated columns (issue 11: per-pair frames concatenated held a
    day's tables twice, 0.5 GB each, beside every pair's inputs; the values are the same).
    The two tables share their time column."""

    _RANGE_FLOATS = ("observed", "rn", "di", "reference", "nlos_estimate")
    _DI_FLOATS = ("di_dr", "di_cp", "di_smoothed", "di_reference")

    def __init__(self, pairs: list[PairInputs], rn: bool) -> None:
        sizes = np.array([p.time_s.shape[0] for p in pairs], dtype=np.int64)
        self._start = np.concatenate(([0], np.cumsum(sizes)))
        n = int(self._start[-1])
        self._names = [p.name for p in pairs]
        self._code = np.repeat(np.arange(len(pairs), dtype=np.int64), sizes)
        self._time = np.empty(n)
        self._range = {c: np.empty(n) for c in self._RANGE_FLOATS}
        self._flag = np.empty(n, dtype=np.int64)
        self._outlier = np.empty(n, dtype=np.int64)
        self._di = {c: np.empty(n) for c in self._DI_FLOATS}
        self._rn = (np.empty(n, dtype=np.int64), np.empty(n)) if rn else None

    def write(
        self,
        i: int,
        p: PairInputs,
        smoothed: SmoothedDI,
        di_dr: FloatArray,
        outs: Mapping[str, DistanceFilterOutput],
    ) -> None:
        rows = slice(int(self._start[i]), int(self._start[i + 1]))
        di_out = outs["di"]
        self._time[rows] = p.time_s
        r = self._range
        r["observed"][rows] = p.observed_m
        r["rn"][rows] = compensated(p.kept_m, outs["rn"]) if "rn" in outs else np.nan
        r["di"][rows] = di_out.distance_m
        r["reference"][rows] = p.reference_m
        self._flag[rows] = di_out.nlos_flag
        self._outlier[rows] = p.outlier
        r["nlos_estimate"][rows] = di_out.nlos_estimate_m
        d = self._di
        d["di_dr"][rows] = di_dr
        d["di_cp"][rows] = p.di_cp_m
        d["di_smoothed"][rows] = smoothed.di_m
        d["di_reference"][rows] = p.di_ref_m
        if self._rn is not None and "rn" in outs:
            self._rn[0][rows] = outs["rn"].nlos_flag
            self._rn[1][rows] = outs["rn"].nlos_estimate_m

    @property
    def rn_nlos(self) -> tuple[NDArray[np.int64], FloatArray] | None:
        return self._rn

    def frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        # the pair column as the per-pair frames gave it: a string array (one take of the
        # distinct names, issue 11), not categorical
        pair = pd.array(self._names, dtype="str").take(self._code)
        self._code = self._code[:0]
        ranges = pd.DataFrame(
            {
                "time": self._time,
                "pair": pair,
                **self._range,
                "nlos_flag": self._flag,
                "outlier": self._outlier,
            },
            columns=list(RANGES_OUT_COLUMNS),
            copy=False,
        )
        di = pd.DataFrame(
            {"time": self._time, "pair": pair, **self._di}, columns=list(DI_COLUMNS), copy=False
        )
        return ranges, di


def compensated(observed_m: FloatArray, out: DistanceFilterOutput) -> FloatArray:
    """RN-Based output: the observed range, minus the held NLOS estimate where flagged;
    where the range was rejected (NaN: a gross outlier) the neighbouring compensated
    ranges interpolated in time (a pass-through has no better prediction: on the real
    `plaza2` session the filter's own constant-velocity prediction was off by up to 5 m).

    Paper 000 Table 2 shows RN-Based leaving the line-of-sight pair A-C unchanged (RMSE
    0.0639 against 0.0641 m observed): the reference method compensates NLOS ranges and
    passes the others through; it does not smooth. Its relative-velocity filter serves the
    detection (eq. (9)) and the one-shot estimate only.
    """
    out_m = np.asarray(observed_m - np.where(out.nlos_flag == 1, out.nlos_estimate_m, 0.0))
    kept = np.isfinite(out_m)
    if kept.all() or not kept.any():
        return out_m
    index = np.arange(out_m.shape[0])
    return np.where(kept, out_m, np.interp(index, index[kept], out_m[kept]))
