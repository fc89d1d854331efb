"""The reporters' input: the tables of one run and its ``run.json`` facts.

:func:`coopproc.report.rundir.load_run` reads it from a run directory; the pipeline
builds it from its in-memory tables with the plain constructor. Its own module, below
the directory reader, so that :mod:`coopproc.report.methods` (which the reader uses)
takes the type without importing the reader (issue 34: no cycle).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["RunTables"]


@dataclass(frozen=True, eq=False)
class RunTables:
    """The tables of one run plus its ``run.json`` facts (``info``).

    Optional tables are None when the run did not produce them; ``nlos_estimates`` may be
    an empty frame.
    """

    ranges: pd.DataFrame
    di: pd.DataFrame
    nlos_events: pd.DataFrame
    nlos_estimates: pd.DataFrame
    positions: pd.DataFrame
    metrics: pd.DataFrame
    position_metrics: pd.DataFrame
    nlos_scores: pd.DataFrame | None = None
    nlos_event_scores: pd.DataFrame | None = None
    info: Mapping[str, Any] = field(default_factory=dict)
    injected_scores: pd.DataFrame | None = None
    evaluation: pd.DataFrame | None = None
    rpe: pd.DataFrame | None = None
    #: velocity and attitude of the INS methods (and the reference's where it has them)
    states: pd.DataFrame | None = None
    #: outages.csv: drift inside the [run] outages windows (coopproc/report/outage.py)
    outages: pd.DataFrame | None = None
    #: dr_states.csv: the fusion's estimate of the followers' dead-reckoning errors
    dr_states: pd.DataFrame | None = None
    #: range_weights.csv: the cooperative fusion's IGG-III factor of every range it used
    range_weights: pd.DataFrame | None = None
    #: comparisons.csv: paired comparisons of methods, 95 % (report/comparisons.py)
    comparisons: pd.DataFrame | None = None
    #: lsq_quality.csv: every epoch of the anchor least squares and its decision
    lsq_quality: pd.DataFrame | None = None

    @property
    def time_origin_s(self) -> float:
        """Earliest time of the ranges and positions tables (0.0 if both are empty)."""
        times = [
            float(np.nanmin(f["time"].to_numpy(dtype=np.float64)))
            for f in (self.ranges, self.positions)
            if len(f) and np.isfinite(f["time"].to_numpy(dtype=np.float64)).any()
        ]
        return min(times) if times else 0.0
