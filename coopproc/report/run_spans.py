"""The spans a run recorded in run.json, read back for the figures: where a platform's
navigation is missing (``nav_gaps``, :func:`~coopproc.checks.coverage.nav_gap_spans`) and
the UWB outage windows the run imposed (``outages.windows``, ``coopproc run --outage``).

The navigation gaps turn the figures' UWB outages there into navigation gaps
(:func:`coopproc.report.gaps.series_gaps`); the outage windows are shaded over the
distance and position errors (:func:`shade_windows`): ranges.csv lists the withheld
ranges in their places (their method columns empty) and the positions go on at the
navigation rate, so no gap marks them otherwise.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.axes import Axes

from coopproc.model import FloatArray
from coopproc.report.gaps import shade_spans

__all__ = ["OUTAGE_WINDOW_SPAN", "nav_gaps_of", "outage_windows_of", "shade_windows"]

#: Style of the run's outage windows: hatched in violet, over the gaps' shading.
OUTAGE_WINDOW_SPAN: dict[str, Any] = {
    "facecolor": "none",
    "edgecolor": "#8e7cc3",
    "hatch": "\\\\\\\\",
    "linewidth": 0.0,
    "zorder": 0.46,
}


def nav_gaps_of(info: Mapping[str, Any]) -> dict[str, FloatArray]:
    """run.json ``nav_gaps`` (per platform, [start, end] in the session time base where its
    navigation is missing) as (k, 2) arrays; empty for a run that predates the key."""
    given = info.get("nav_gaps")
    if not isinstance(given, Mapping):
        return {}
    return {str(p): np.asarray(s, dtype=np.float64).reshape(-1, 2) for p, s in given.items()}


def outage_windows_of(info: Mapping[str, Any]) -> FloatArray:
    """(k, 2) start and end (session time base) of run.json ``outages.windows``: the UWB
    outages the run imposed (``--outage``, ``[run] outages``); empty without."""
    outages = info.get("outages")
    windows = outages.get("windows") if isinstance(outages, Mapping) else None
    if not isinstance(windows, list):
        return np.empty((0, 2), dtype=np.float64)
    spans = [(float(w["start"]), float(w["end"])) for w in windows if isinstance(w, Mapping)]
    return np.array(spans, dtype=np.float64).reshape(-1, 2)


def shade_windows(ax: Axes, windows: FloatArray) -> None:
    """Shade the run's outage windows (times as drawn) on ``ax``, hatched (``gid``
    ``outage_window``, legend "Outage window"): the ranges there are withheld from every
    method, although ranges.csv lists them (their method columns empty)."""
    shade_spans(ax, windows, "outage_window", "Outage window", OUTAGE_WINDOW_SPAN)
