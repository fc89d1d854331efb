"""The run's scoring tables against the reference: ``nlos_scores.csv`` and
``nlos_event_scores.csv`` (docs/report.md).

The range processors' NLOS decisions are scored per pair and method
(:func:`~coopproc.report.scores.nlos_scores`), the fusion's own outlier decisions the same
way as ``fusion:<method>`` rows (:func:`~coopproc.report.outlier_scores.fusion_outlier_scores`),
and each row says how the pair's filter ran (``mode``, ``ranges_only_fraction``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from coopproc.report.metrics import nlos_scores
from coopproc.report.outlier_scores import fusion_outlier_scores
from coopproc.report.scores import nlos_event_scores
from coopproc.stages.base import RangeProduct

__all__ = ["score_tables"]


def score_tables(
    table: pd.DataFrame,
    events: pd.DataFrame,
    label_sigma: Mapping[str, float],
    nlos_methods: tuple[str, ...],
    range_weights: pd.DataFrame | None,
    position_methods: tuple[str, ...],
    range_products: Sequence[RangeProduct],
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(nlos_scores, nlos_event_scores, the fusion outlier scores) of a run: ``table`` is
    ranges.csv's, ``events`` nlos_events.csv's, ``label_sigma`` the sigma true NLOS is
    labelled against per pair, ``position_methods`` the position methods in chain order."""
    event_scores = nlos_event_scores(table, events)
    scores = nlos_scores(
        table, events, label_sigma, methods=nlos_methods, event_scores=event_scores
    )
    # the fusion's own outlier decisions, scored the same way (report/outlier_scores.py)
    with_weights = (
        set() if range_weights is None else {str(m) for m in range_weights["method"].unique()}
    )
    weighted = tuple(m for m in position_methods if m in with_weights)  # in chain order
    outliers = fusion_outlier_scores(table, range_weights, label_sigma, methods=weighted)
    if len(outliers):
        rows = outliers[list(scores.columns)]
        scores = pd.concat([scores, rows], ignore_index=True) if len(scores) else rows
    return _with_modes(scores, range_products), event_scores, outliers


def _with_modes(scores: pd.DataFrame, products: Sequence[RangeProduct]) -> pd.DataFrame:
    """nlos_scores.csv's ``mode`` and ``ranges_only_fraction`` (issue 30.3): how the pair's
    filter of the method ran, ``di`` (smoothing with the DI in every calibration window),
    ``ranges`` (ranges-only in every window) or ``mixed``, and the share of its epochs in
    ranges-only windows; empty for the rows of methods without windows (fusion:*)."""
    share = {k: c.ranges_only_fraction for p in products for k, c in p.calibration.items()}
    frac = np.array(
        [
            share.get((pair, m), np.nan)
            for pair, m in zip(scores["pair"], scores["method"], strict=True)
        ],
        dtype=np.float64,
    )
    mode = np.where(
        np.isnan(frac), "", np.where(frac <= 0.0, "di", np.where(frac >= 1.0, "ranges", "mixed"))
    )
    return scores.assign(mode=mode, ranges_only_fraction=frac)
