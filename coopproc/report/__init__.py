"""Reporters: statistics, tables, figures and HTML page of a run (paper 000 Tables 2-3, figs. 8-12).

Everything reads the output tables (an output directory via :func:`load_run`, or the
pipeline's in-memory tables wrapped in :class:`RunTables`), so a report is remade without
recomputing. Figures and HTML (matplotlib) are imported on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from coopproc.report.formats import format_tables
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run
from coopproc.report.scores import nlos_event_scores, nlos_scores

__all__ = [
    "RunTables",
    "distance_metrics",
    "format_tables",
    "load_run",
    "nlos_event_scores",
    "nlos_scores",
    "position_metrics",
    "write_figures",
    "write_html",
]

_LAZY = {"write_figures": "coopproc.report.figures", "write_html": "coopproc.report.html"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'coopproc.report' has no attribute {name!r}")
