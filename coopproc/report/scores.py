"""NLOS detection scored against the reference (beyond paper 000; issue 6 item 7).

Truth label: a range epoch of a pair is NLOS when ``observed - reference > 3 sigma`` (one
sided: NLOS only lengthens a range), the same 3-sigma rule as the detector's gamma_max
(paper 000, eq. (9)). Only epochs with a reference distance are scored.

Detection: an epoch is detected by a method when its time lies in ``[start, end]``
(both inclusive) of one of that method's events of that pair in ``nlos_events``.

Per pair and method: tp, fp, fn over the scored epochs, precision = tp / (tp + fp),
recall = tp / (tp + fn), F1 = 2 tp / (2 tp + fp + fn) (= 2 P R / (P + R)); each NaN where
its denominator is 0.
Per event: the reference-derived bias is the mean of ``observed - reference`` over the
event's epochs that have a reference; the event's error is ``estimate - bias`` (signed).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import NLOS_EVENT_COLUMNS, FloatArray
from coopproc.report.methods import detection_methods_of, range_methods_of

__all__ = [
    "NLOS_EVENT_SCORE_COLUMNS",
    "NLOS_SCORE_COLUMNS",
    "detection_methods",
    "event_bias",
    "nlos_event_scores",
    "nlos_scores",
    "robust_sigma",
    "true_nlos",
]

NLOS_SCORE_COLUMNS: tuple[str, ...] = (
    "pair",
    "method",
    "sigma",
    "epochs",
    "nlos_true",
    "detected",
    "tp",
    "fp",
    "fn",
    "precision",
    "recall",
    "f1",
    "events",
    "estimate_mae",
    "estimate_max_error",
)
NLOS_EVENT_SCORE_COLUMNS: tuple[str, ...] = (
    "pair",
    "method",
    "start",
    "end",
    "epochs",
    "estimate",
    "reference_bias",
    "error",
)

#: Consistency constant of the median absolute deviation for a normal distribution.
_MAD_TO_SIGMA = 1.4826


def robust_sigma(residual_m: FloatArray) -> float:
    """1.4826 x the median absolute deviation of the finite residuals (NaN if none)."""
    x = np.asarray(residual_m, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan")
    return float(_MAD_TO_SIGMA * np.median(np.abs(x - np.median(x))))


def true_nlos(observed_m: FloatArray, reference_m: FloatArray, sigma_m: float) -> FloatArray:
    """1.0 where observed - reference > 3 sigma, 0.0 where not, NaN without a reference."""
    e = np.asarray(observed_m, dtype=np.float64) - np.asarray(reference_m, dtype=np.float64)
    out = np.where(e > 3.0 * sigma_m, 1.0, 0.0)
    out[~np.isfinite(e)] = np.nan
    return out


def detection_methods(ranges: pd.DataFrame, nlos_events: pd.DataFrame) -> list[str]:
    """Methods that detect NLOS, derived from the tables: the range methods of ``ranges``
    that are known detectors (``rn``, ``di``) or have events, then others with events
    (:func:`~coopproc.report.methods.detection_methods_of`)."""
    return list(detection_methods_of(range_methods_of(ranges), nlos_events))


def _in_events(time_s: FloatArray, starts: FloatArray, ends: FloatArray) -> NDArray[np.bool_]:
    """Epochs of ``time_s`` (sorted ascending, NaN last) inside any ``[start, end]``: the
    same as ``(t >= start) & (t <= end)`` per event, by two binary searches an event."""
    n = time_s.shape[0]
    ok = ~(np.isnan(starts) | np.isnan(ends))  # no epoch compares True with NaN
    lo = np.searchsorted(time_s, starts[ok], side="left")
    hi = np.searchsorted(time_s, ends[ok], side="right")
    spans = lo < hi
    depth = np.zeros(n + 1, dtype=np.int64)
    np.add.at(depth, lo[spans], 1)
    np.add.at(depth, hi[spans], -1)
    return np.cumsum(depth[:n]) > 0


def _pair_rows(ranges: pd.DataFrame) -> tuple[list[str], NDArray[np.intp], NDArray[np.intp]]:
    """Pairs by name and the rows of each in time order (stable), as index arrays: pair k
    is ``order[bounds[k]:bounds[k + 1]]`` (``sort_values(["pair", "time"])`` without a
    sorted copy of the table or a string comparison per row)."""
    codes, pairs = pd.factorize(ranges["pair"], sort=True)
    time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    order = np.lexsort((time, codes))
    order = order[codes[order] >= 0]  # rows without a pair are in no group
    bounds = np.searchsorted(codes[order], np.arange(len(pairs) + 1))
    return [str(p) for p in pairs], order, bounds


def event_bias(pair_ranges: pd.DataFrame, start_s: float, end_s: float) -> tuple[float, int]:
    """Mean of observed - reference over ``[start_s, end_s]`` and the epochs it used."""
    t = pair_ranges["time"].to_numpy(dtype=np.float64)
    e = pair_ranges["observed"].to_numpy(dtype=np.float64, na_value=np.nan) - pair_ranges[
        "reference"
    ].to_numpy(dtype=np.float64, na_value=np.nan)
    keep = (t >= start_s) & (t <= end_s) & np.isfinite(e)
    n = int(np.count_nonzero(keep))
    return (float(np.mean(e[keep])) if n else float("nan")), n


def _ratio(num: int, den: int) -> float:
    return num / den if den else float("nan")


def _pair_sigma(pair: str, sigma: Mapping[str, float], residual: FloatArray) -> float:
    given = sigma.get(pair)
    if given is not None and np.isfinite(given) and given > 0:
        return float(given)
    return robust_sigma(residual)


def nlos_event_scores(ranges: pd.DataFrame, nlos_events: pd.DataFrame) -> pd.DataFrame:
    """Every NLOS event's estimate against the reference-derived bias (NLOS_EVENT_SCORE_COLUMNS)."""
    rows: list[dict[str, object]] = []
    events = nlos_events.sort_values(["pair", "method", "start"], kind="stable")
    pairs, order, bounds = _pair_rows(ranges)
    at_pair = {pair: k for k, pair in enumerate(pairs)}
    time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    error = ranges["observed"].to_numpy(dtype=np.float64, na_value=np.nan) - ranges[
        "reference"
    ].to_numpy(dtype=np.float64, na_value=np.nan)
    sorted_t: dict[int, tuple[FloatArray, FloatArray]] = {}
    starts, ends = events["start"].to_numpy(float), events["end"].to_numpy(float)
    estimates = events["estimate"].to_numpy(float)
    for i, (pair, method) in enumerate(zip(events["pair"], events["method"], strict=True)):
        k = at_pair.get(str(pair))
        bias, n = (float("nan"), 0)
        if k is not None:
            if k not in sorted_t:
                at = order[bounds[k] : bounds[k + 1]]
                sorted_t[k] = (time[at], error[at])
            bias, n = _bias_sorted(*sorted_t[k], float(starts[i]), float(ends[i]))
        estimate = float(estimates[i])
        rows.append(
            {
                "pair": str(pair),
                "method": str(method),
                "start": float(starts[i]),
                "end": float(ends[i]),
                "epochs": n,
                "estimate": estimate,
                "reference_bias": bias,
                "error": estimate - bias,
            }
        )
    out = pd.DataFrame(rows, columns=list(NLOS_EVENT_SCORE_COLUMNS))
    out["epochs"] = out["epochs"].astype(np.int64)
    return out


def _bias_sorted(
    time_s: FloatArray, error_m: FloatArray, start_s: float, end_s: float
) -> tuple[float, int]:
    """:func:`event_bias` on a pair's rows in time order (NaN times last): the rows in
    ``[start_s, end_s]`` are one slice, found by binary search."""
    if np.isnan(start_s) or np.isnan(end_s):  # no epoch compares True with NaN
        return float("nan"), 0
    lo = int(np.searchsorted(time_s, start_s, side="left"))
    hi = int(np.searchsorted(time_s, end_s, side="right"))
    e = error_m[lo:hi] if lo < hi else error_m[:0]
    e = e[np.isfinite(e)]
    n = int(e.shape[0])
    return (float(np.mean(e)) if n else float("nan")), n


def nlos_scores(
    ranges: pd.DataFrame,
    nlos_events: pd.DataFrame,
    sigma: Mapping[str, float],
    methods: Sequence[str] | None = None,
    event_scores: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Precision, recall and F1 of NLOS detection per pair and method (``nlos_scores.csv``).

    ``sigma``: ranging 1-sigma (m) per pair, the one the detector used; a pair missing
    from it (or with a non-positive value) gets 1.4826 MAD of observed - reference.
    Also the count of events and the mean absolute / maximum absolute error of their
    estimates against the reference-derived bias (:func:`nlos_event_scores`; pass
    ``event_scores`` when already computed). ``methods``: the methods scored, in order
    (the run's :func:`~coopproc.report.methods.nlos_methods`); by default
    :func:`detection_methods`. Columns :data:`NLOS_SCORE_COLUMNS`; a pair with no
    reference has epochs = 0.
    """
    missing = [c for c in NLOS_EVENT_COLUMNS if c not in nlos_events.columns]
    if missing:
        raise ValueError(f"nlos_events table lacks columns {missing}")
    if methods is None:
        methods = detection_methods(ranges, nlos_events)
    if event_scores is None:
        event_scores = nlos_event_scores(ranges, nlos_events)
    events_of = _rows_by_key(nlos_events)
    errors_of = _rows_by_key(event_scores)
    starts = nlos_events["start"].to_numpy(float)
    ends = nlos_events["end"].to_numpy(float)
    event_error = event_scores["error"].to_numpy(dtype=np.float64)
    time = ranges["time"].to_numpy(dtype=np.float64, na_value=np.nan)
    observed = ranges["observed"].to_numpy(dtype=np.float64, na_value=np.nan)
    reference = ranges["reference"].to_numpy(dtype=np.float64, na_value=np.nan)
    pairs, order, bounds = _pair_rows(ranges)
    rows: list[dict[str, object]] = []
    for k, pair in enumerate(pairs):
        at = order[bounds[k] : bounds[k + 1]]
        t, obs, ref = time[at], observed[at], reference[at]
        s = _pair_sigma(pair, sigma, obs - ref)
        label = true_nlos(obs, ref, s)
        scored = np.isfinite(label)
        truth = np.asarray(label[scored] == 1.0, dtype=bool)
        for method in methods:
            mine = events_of.get((pair, str(method)), _NONE)
            detected = np.asarray(_in_events(t, starts[mine], ends[mine])[scored], dtype=bool)
            tp = int(np.count_nonzero(truth & detected))
            fp = int(np.count_nonzero(~truth & detected))
            fn = int(np.count_nonzero(truth & ~detected))
            precision, recall = _ratio(tp, tp + fp), _ratio(tp, tp + fn)
            f1 = _ratio(2 * tp, 2 * tp + fp + fn)  # = 2 P R / (P + R); 0 when tp = 0
            errs = event_error[errors_of.get((pair, str(method)), _NONE)]
            errs = np.abs(errs[np.isfinite(errs)])
            rows.append(
                {
                    "pair": pair,
                    "method": method,
                    "sigma": s,
                    "epochs": int(np.count_nonzero(scored)),
                    "nlos_true": int(np.count_nonzero(truth)),
                    "detected": int(np.count_nonzero(detected)),
                    "tp": tp,
                    "fp": fp,
                    "fn": fn,
                    "precision": precision,
                    "recall": recall,
                    "f1": f1,
                    "events": int(mine.shape[0]),
                    "estimate_mae": float(np.mean(errs)) if errs.size else float("nan"),
                    "estimate_max_error": float(np.max(errs)) if errs.size else float("nan"),
                }
            )
    out = pd.DataFrame(rows, columns=list(NLOS_SCORE_COLUMNS))
    for col in ("epochs", "nlos_true", "detected", "tp", "fp", "fn", "events"):
        out[col] = out[col].astype(np.int64)
    return out


_NONE: NDArray[np.intp] = np.empty(0, dtype=np.intp)


def _rows_by_key(frame: pd.DataFrame) -> dict[tuple[str, str], NDArray[np.intp]]:
    """Row positions of each (pair, method) of an events table, in the table's order."""
    groups: dict[tuple[str, str], list[int]] = {}
    for i, key in enumerate(zip(frame["pair"], frame["method"], strict=True)):
        groups.setdefault((str(key[0]), str(key[1])), []).append(i)
    return {k: np.asarray(v, dtype=np.intp) for k, v in groups.items()}
