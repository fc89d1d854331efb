"""The panels of the NLOS convergence figure: one per event of the primary method.

Grouped once: the estimates per (pair, method, event), the events and ranges per pair;
each event's reference bias comes from its own pair's ranges, not from a scan of the
whole range table.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from coopproc.report.methods import nlos_methods, primary_method
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import groups
from coopproc.report.rundir import RunTables
from coopproc.report.scores import event_bias

__all__ = ["convergence_panels"]


def _primary_estimates(run: RunTables) -> str | None:
    est = run.nlos_estimates
    if est is None or not len(est):
        return None
    have = {str(m) for m in est["method"].unique()}
    preferred = [m for m in (primary_method(run), *nlos_methods(run)) if m in have]
    return preferred[0] if preferred else sorted(have)[0]


def convergence_panels(
    run: RunTables, options: FigureOptions | None = None
) -> list[tuple[str, pd.DataFrame, float | None]]:
    """(title, estimate rows of every method, reference bias) per event of the primary method.

    The primary method is the run's (:func:`~coopproc.report.methods.primary_method`) if
    it has estimates, else the first NLOS method with estimates, else the first by name.
    Events of other methods of the same pair join the panel whose time span they overlap
    (spans widened by one step spacing). ``options``: only the chosen pairs.
    """
    opts = options or FigureOptions()
    primary = _primary_estimates(run)
    est = run.nlos_estimates
    if primary is None or est is None:
        return []
    # every event's estimates grouped once, then indexed by pair
    spans: dict[str, list[tuple[str, Any, float, float, pd.DataFrame]]] = {}
    for (pair, method, event), rows in est.groupby(["pair", "method", "event"], sort=True):
        if opts.keep_pair(str(pair)):
            t = rows["time"].to_numpy(dtype=np.float64)
            spans.setdefault(str(pair), []).append(
                (str(method), event, float(t.min()), float(t.max()), rows)
            )
    events = groups(run.nlos_events, "pair")
    ranges = groups(run.ranges, "pair") if spans else {}
    panels = []
    for pair in sorted(spans):
        for method, event, lo, hi, rows in spans[pair]:
            if method != primary:
                continue
            times = np.sort(rows["time"].to_numpy(dtype=np.float64))
            dt = float(np.median(np.diff(times))) if len(rows) > 1 else 1.0
            parts = [rows]
            for m2, _, lo2, hi2, rows2 in spans[pair]:
                if m2 != primary and lo2 <= hi + dt and hi2 >= lo - dt:
                    parts.append(rows2)
            bias = _event_reference_bias(events.get(pair), ranges.get(pair), method, lo)
            title = f"{pair}, event {event} (t = {lo - run.time_origin_s:.0f} s)"
            panels.append((title, pd.concat(parts), bias))
    return panels


def _event_reference_bias(
    pair_events: pd.DataFrame | None, pair_ranges: pd.DataFrame | None, method: str, first_s: float
) -> float | None:
    """The reference bias over the ``method`` event of the pair nearest ``first_s``."""
    if pair_events is None or pair_ranges is None:
        return None
    events = pair_events[pair_events["method"] == method]
    if not len(events):
        return None
    nearest = events.iloc[int(np.argmin(np.abs(events["start"].to_numpy(float) - first_s)))]
    bias, n = event_bias(pair_ranges, float(nearest["start"]), float(nearest["end"]))
    return bias if n else None
