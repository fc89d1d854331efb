"""What :func:`coopproc.run.pipeline.run_pipeline` returns: the result tables and what
run.json and the closing summary report.

Its own module so that the readers of a run's output (``run.output``, ``run.summary``,
``run.calibration_summary``) and the outage runner (``run.outages``, which wraps
``run_pipeline``) take the type without importing the pipeline (issue 34: no cycle).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import pandas as pd

from coopproc.model import Result
from coopproc.run.chain import Step
from coopproc.run.declared_sigma import DeclaredSigma
from coopproc.stages.base import PositionCalibration, RangeCalibration
from coopproc.stages.fusion.dr_quality import DeadReckoningQuality

__all__ = ["PipelineOutput"]


@dataclass(frozen=True, eq=False)
class PipelineOutput:
    """The result tables plus what run.json and the closing summary report."""

    result: Result
    nlos_scores: pd.DataFrame
    nlos_event_scores: pd.DataFrame
    timings_s: Mapping[str, float]
    sigma: Mapping[str, tuple[float, str]]
    #: the range processors' self-calibration, (pair, method) -> figures
    ranging_calibration: Mapping[tuple[str, str], RangeCalibration]
    #: each position method's self-calibration (the fusions'), by method
    fusion_calibration: Mapping[str, PositionCalibration]
    #: each moving platform's dead reckoning against the observed cooperative solution
    dr_quality: Mapping[str, DeadReckoningQuality]
    notes: tuple[str, ...]
    #: the steps that ran, in order
    chain: tuple[Step, ...] = ()
    #: the run's methods: "ranges" (observed first, ranges.csv order) and "positions"
    methods: Mapping[str, tuple[str, ...]] | None = None
    #: the range methods that detect NLOS, in chain order
    nlos_methods: tuple[str, ...] = ()
    #: the fusion's outlier decisions scored (report/outlier_scores.py): the
    #: ``fusion:<method>`` rows of ``nlos_scores`` and their ``rejected_tp``
    fusion_outlier_scores: pd.DataFrame | None = None
    #: methods whose positions jump or whose covariance exploded (run/implausible.py)
    implausible: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    #: the declared ``[uwb] sigma`` against the data (run/declared_sigma.py)
    declared_sigma: DeclaredSigma | None = None
