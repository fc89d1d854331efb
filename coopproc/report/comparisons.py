"""Paired comparisons of methods for Table 2 and Table 3 (``comparisons.csv``).

For each pair (Table 2) and platform (Table 3), each method against ``observed`` and
``di`` against ``rn`` (:func:`~coopproc.report.intervals.comparison_pairs`): the
difference of RMSE and of mean error with its block-bootstrap interval and p-value, the
same blocks drawn for both methods (:func:`~coopproc.report.intervals.paired_difference`).
Table 2 pairs the range rows where both methods and the reference have a value (the
signed errors ``e_i``); Table 3 the epochs both methods have at the same time (the
horizontal errors ``h_i``). The report's change column marks the changes against
Observed whose p-value is below ``--significance``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.report.intervals import comparison_frame, comparison_pairs, paired_difference
from coopproc.report.metrics import REFERENCE_METHOD, _codes, _group_rows

__all__ = ["comparisons", "distance_comparisons", "position_comparisons"]


def distance_comparisons(
    ranges: pd.DataFrame, methods: Sequence[str], level: float
) -> list[dict[str, object]]:
    """The Table 2 rows of ``comparisons.csv`` (``kind`` ``pair``), by pair then in the
    order of :func:`comparison_pairs`."""
    methods = [m for m in methods if m in ranges.columns]
    pairs_of = comparison_pairs(methods)
    rows: list[dict[str, object]] = []
    if not pairs_of or not len(ranges):
        return rows
    codes, pairs = pd.factorize(ranges["pair"], sort=True)
    time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    order = np.lexsort((time, codes))
    order = order[codes[order] >= 0]
    bounds = np.searchsorted(codes[order], np.arange(len(pairs) + 1))
    reference = ranges["reference"].to_numpy(dtype=np.float64, na_value=np.nan)
    values = {m: ranges[m].to_numpy(dtype=np.float64, na_value=np.nan) for m in methods}
    for k, pair in enumerate(pairs):
        at = order[bounds[k] : bounds[k + 1]]
        ref = reference[at]
        for method, baseline in pairs_of:
            a, b = values[method][at] - ref, values[baseline][at] - ref
            names = ("pair", str(pair), method, baseline)
            rows.append(
                {
                    "kind": "pair",
                    "group": str(pair),
                    "method": method,
                    "baseline": baseline,
                    **paired_difference(a, b, level, names),
                }
            )
    return rows


def position_comparisons(
    positions: pd.DataFrame, methods: Sequence[str], level: float
) -> list[dict[str, object]]:
    """The Table 3 rows of ``comparisons.csv`` (``kind`` ``platform``): ``methods`` the
    rows of Table 3 (``nav`` and the run's position methods), epochs matched on time."""
    rows: list[dict[str, object]] = []
    if not len(positions):
        return rows
    platform, platform_names = _codes(positions["platform"])
    method, method_names = _codes(positions["method"])
    time = positions["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    error = positions["error_h"].to_numpy(dtype=np.float64, na_value=np.nan)
    groups = _group_rows(platform, method, time)
    for p, name in enumerate(platform_names):
        mine = {
            method_names[m]: at
            for (q, m), at in groups.items()
            if q == p and m >= 0 and method_names[m] != REFERENCE_METHOD
        }
        present = [m for m in methods if m in mine]
        for meth, baseline in comparison_pairs(present):
            t_a, t_b = time[mine[meth]], time[mine[baseline]]
            _common, ia, ib = np.intersect1d(t_a, t_b, return_indices=True)
            a, b = error[mine[meth]][ia], error[mine[baseline]][ib]
            names = ("platform", name, meth, baseline)
            rows.append(
                {
                    "kind": "platform",
                    "group": name,
                    "method": meth,
                    "baseline": baseline,
                    **paired_difference(a, b, level, names),
                }
            )
    return rows


def comparisons(
    ranges: pd.DataFrame,
    positions: pd.DataFrame,
    range_methods: Sequence[str],
    position_methods: Sequence[str],
    level: float,
) -> pd.DataFrame:
    """``comparisons.csv``: the Table 2 rows, then the Table 3 rows (module doc)."""
    rows = distance_comparisons(ranges, range_methods, level)
    rows += position_comparisons(positions, position_methods, level)
    return comparison_frame(rows)
