"""The fusion's outlier decisions scored against the reference, like NLOS detection.

``range_weights.csv`` (:mod:`coopproc.stages.fusion.range_weights`) gives the IGG-III
factor gamma the cooperative fusion used for every range. Scored per pair and fusion
method, as rows of ``nlos_scores.csv`` (:data:`~coopproc.report.scores.NLOS_SCORE_COLUMNS`)
with the method ``fusion:<method>`` (``fusion:observed``, ``fusion:rn``, ``fusion:di``):

- **Truth label**: a range is an outlier when its error against the reference,
  ``|range - reference|`` (the range the fusion took: the ``observed`` column of
  ranges.csv for ``fusion:observed``, the ``rn`` / ``di`` column for those sets), exceeds
  3 sigma, with the pair's sigma of the NLOS rows (the declared ``[uwb] sigma``, else
  1.4826 MAD of observed - reference: :func:`~coopproc.report.scores.nlos_scores`). Two
  sided, unlike NLOS: a range the fusion should not trust may read short as well as long.
- **Detection**: the range was down-weighted (gamma < 1).
- ``tp, fp, fn, precision, recall, f1`` as for NLOS, over the ranges with a reference
  (``epochs``); ``nlos_true`` counts the outliers, ``detected`` the down-weighted ranges,
  ``events`` the rejected ones (gamma 0, beyond ``[fusion] k1``); no estimate, so
  ``estimate_mae`` and ``estimate_max_error`` are empty. :func:`fusion_outlier_scores`
  also gives ``rejected_tp``, the rejected ranges that are outliers (run.json's summary;
  not a column of nlos_scores.csv).

A range of range_weights.csv is matched to ranges.csv by pair and time (the first row of
that pair at that time, as :func:`~coopproc.run.range_sets.row_sigma` matches).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.scores import NLOS_SCORE_COLUMNS, robust_sigma

__all__ = ["FUSION_PREFIX", "fusion_outlier_scores", "fusion_score_method"]

#: The nlos_scores.csv method of a fusion method's outlier decisions: ``fusion:<method>``.
FUSION_PREFIX = "fusion:"

#: Outlier threshold in sigmas: the NLOS label's (paper 000's gamma_max, eq. (9)).
OUTLIER_SIGMAS = 3.0


def fusion_score_method(method: str) -> str:
    """``fusion:observed`` for the fusion of the observed ranges, and so on."""
    return FUSION_PREFIX + method


def _matched(
    times: FloatArray, wanted: FloatArray
) -> tuple[np.ndarray, np.ndarray]:  # (row in times, found)
    order = np.argsort(times, kind="stable")
    sorted_t = times[order]
    first = np.searchsorted(sorted_t, wanted, side="left")
    inside = np.minimum(first, max(sorted_t.shape[0] - 1, 0))
    if sorted_t.shape[0] == 0:
        return inside, np.zeros(wanted.shape[0], dtype=bool)
    found = (first < sorted_t.shape[0]) & (sorted_t[inside] == wanted)
    return order[inside], found


def _codes_in(values: pd.Series, names: list[str]) -> np.ndarray:
    """Each value's position in ``names`` (-1 where absent): one factorization and a
    lookup per distinct value."""
    raw, uniques = pd.factorize(values)
    lut = np.append(pd.Index(names).get_indexer(pd.Index([str(u) for u in uniques])), -1)
    return np.asarray(lut[raw], dtype=np.int64)


def fusion_outlier_scores(
    ranges: pd.DataFrame,
    weights: pd.DataFrame | None,
    sigma: Mapping[str, float],
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """nlos_scores.csv rows of the fusion's decisions (module docstring) and
    ``rejected_tp``, per pair (name order) and method (``methods``' order, default the
    weights' methods in name order).

    ``ranges``: ranges.csv's table (``time, pair, observed, <methods>, reference``);
    ``weights``: range_weights.csv's (``time, pair, method, gamma, rejected``); ``sigma``:
    the NLOS label's sigma per pair (missing or non-positive: 1.4826 MAD of observed -
    reference)."""
    columns = [*NLOS_SCORE_COLUMNS, "rejected_tp"]
    if weights is None or not len(weights) or not len(ranges):
        return pd.DataFrame(columns=columns)
    if methods is None:
        methods = sorted({str(m) for m in weights["method"].unique()})
    r_codes, r_pairs = pd.factorize(ranges["pair"], sort=True)
    r_time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    observed = ranges["observed"].to_numpy(dtype=np.float64, na_value=np.nan)
    reference = ranges["reference"].to_numpy(dtype=np.float64, na_value=np.nan)
    # integer codes of the few distinct pairs and methods (no string compared per row)
    w_codes = _codes_in(weights["pair"], [str(p) for p in r_pairs])  # -1: not in ranges.csv
    w_method = _codes_in(weights["method"], [str(m) for m in methods])
    w_time = weights["time"].to_numpy(dtype=np.float64)
    gamma = weights["gamma"].to_numpy(dtype=np.float64)
    rejected = weights["rejected"].to_numpy(dtype=np.int64)
    value_of = {
        m: (ranges[m] if m in ranges.columns else ranges["observed"]).to_numpy(
            dtype=np.float64, na_value=np.nan
        )
        for m in methods
    }
    r_order = np.argsort(r_codes, kind="stable")
    r_bounds = np.searchsorted(r_codes[r_order], np.arange(len(r_pairs) + 1))
    w_order = np.lexsort((w_codes,))
    w_bounds = np.searchsorted(w_codes[w_order], np.arange(len(r_pairs) + 1))
    rows: list[dict[str, object]] = []
    for k, pair in enumerate(r_pairs):
        mine = r_order[r_bounds[k] : r_bounds[k + 1]]
        given = sigma.get(str(pair))
        s = (
            float(given)
            if given is not None and np.isfinite(given) and given > 0
            else robust_sigma(observed[mine] - reference[mine])
        )
        theirs = w_order[w_bounds[k] : w_bounds[k + 1]]
        at, found = _matched(r_time[mine], w_time[theirs])
        row_of = mine[at]
        for code, method in enumerate(methods):
            value = value_of[method]
            sel = w_method[theirs] == code
            error = np.where(found[sel], value[row_of[sel]] - reference[row_of[sel]], np.nan)
            scored = np.isfinite(error)
            truth = np.abs(error[scored]) > OUTLIER_SIGMAS * s
            down = gamma[theirs[sel]][scored] < 1.0
            out_rejected = rejected[theirs[sel]][scored] == 1
            tp = int(np.count_nonzero(truth & down))
            fp = int(np.count_nonzero(~truth & down))
            fn = int(np.count_nonzero(truth & ~down))
            rows.append(
                {
                    "pair": str(pair),
                    "method": fusion_score_method(method),
                    "sigma": s,
                    "epochs": int(np.count_nonzero(scored)),
                    "nlos_true": int(np.count_nonzero(truth)),
                    "detected": int(np.count_nonzero(down)),
                    "tp": tp,
                    "fp": fp,
                    "fn": fn,
                    "precision": tp / (tp + fp) if tp + fp else float("nan"),
                    "recall": tp / (tp + fn) if tp + fn else float("nan"),
                    "f1": 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else float("nan"),
                    "events": int(np.count_nonzero(out_rejected)),
                    "estimate_mae": float("nan"),
                    "estimate_max_error": float("nan"),
                    "rejected_tp": int(np.count_nonzero(truth & out_rejected)),
                }
            )
    out = pd.DataFrame(rows, columns=columns)
    for col in ("epochs", "nlos_true", "detected", "tp", "fp", "fn", "events", "rejected_tp"):
        out[col] = out[col].astype(np.int64)
    return out
