"""How the report's tables show each statistic and method: :class:`MetricSpec` (header
label, unit, decimals, which value is best), the display names of methods, and the printed
form of a value (:func:`number_text`), which also decides ties: two values are equal when
they print the same.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Literal

__all__ = [
    "METHOD_LABELS",
    "METRIC_SPECS",
    "Better",
    "MetricSpec",
    "method_label",
    "number_text",
    "run_labels",
]

Better = Literal["min", "max", "absmin", "one"]

#: Display names of methods (paper 000 names RN-Based and DI-Based).
METHOD_LABELS: dict[str, str] = {
    "observed": "Observed",
    "rn": "RN-Based",
    "di": "DI-Based",
    "nav": "Own nav",
}


#: The display names the run being reported declares (run.json ``"method_labels"``: what
#: the stage registry calls each method of its chain), entered with :func:`run_labels`.
_RUN_LABELS: ContextVar[Mapping[str, str] | None] = ContextVar("run_labels", default=None)


def method_label(method: str) -> str:
    """The display name of a method: the run's own (:func:`run_labels`), else
    :data:`METHOD_LABELS`, else the method's own name."""
    declared = _RUN_LABELS.get()
    named = declared.get(method) if declared is not None else None
    return named or METHOD_LABELS.get(method, method)


@contextlib.contextmanager
def run_labels(info: Mapping[str, Any]) -> Iterator[None]:
    """Within it, :func:`method_label` names the methods as the run's ``run.json`` facts
    (``info``) do: its ``"method_labels"`` (a run before them: the defaults). Entered by
    whatever reports one run (``coopproc report``, the run's own figures and report.html);
    forked page workers inherit it."""
    labels = info.get("method_labels")
    named = {str(k): str(v) for k, v in labels.items()} if isinstance(labels, dict) else {}
    token = _RUN_LABELS.set(named)
    try:
        yield
    finally:
        _RUN_LABELS.reset(token)


def number_text(name: str, value: float) -> str:
    """A statistic's value as the tables print it: the decimals of its :class:`MetricSpec`,
    ``-`` for NaN, ``inf`` / ``-inf``."""
    if value != value:  # NaN
        return "-"
    if value in (float("inf"), float("-inf")):
        return "inf" if value > 0 else "-inf"
    return f"{value:.{METRIC_SPECS.get(name, MetricSpec(name)).decimals}f}"


@dataclass(frozen=True)
class MetricSpec:
    """How one statistic is shown: header label, unit, decimals, which value is best."""

    label: str
    unit: str = ""
    decimals: int = 4
    #: min / max: smallest / largest; absmin: smallest magnitude; one: closest to 1.
    better: Better | None = "min"
    #: The statistic can be negative (a bias): its change against Observed is absolute.
    signed: bool = False


METRIC_SPECS: dict[str, MetricSpec] = {
    "max": MetricSpec("Max", "m"),
    "mean": MetricSpec("Mean", "m", better="absmin"),
    "rmse": MetricSpec("RMSE", "m"),
    "snr_db": MetricSpec("SNR", "dB", 2, "max"),
    "smoothness": MetricSpec("Smoothness", "", 4, "one"),
    "rms_east": MetricSpec("RMS E", "m"),
    "rms_north": MetricSpec("RMS N", "m"),
    "cep50": MetricSpec("CEP50", "m"),
    "cep95": MetricSpec("CEP95", "m"),
    # Table 3 per axis (coopproc.report.axis_metrics)
    "rms_up": MetricSpec("RMS U", "m"),
    "max_east": MetricSpec("Max E", "m"),
    "max_north": MetricSpec("Max N", "m"),
    "max_up": MetricSpec("Max U", "m"),
    "rms_vel_east": MetricSpec("RMS vE", "m/s"),
    "rms_vel_north": MetricSpec("RMS vN", "m/s"),
    "rms_vel_up": MetricSpec("RMS vU", "m/s"),
    "rms_roll": MetricSpec("RMS roll", "deg", 3),
    "rms_pitch": MetricSpec("RMS pitch", "deg", 3),
    "rms_yaw": MetricSpec("RMS yaw", "deg", 3),
    "precision": MetricSpec("Precision", "", 3, "max"),
    "recall": MetricSpec("Recall", "", 3, "max"),
    "f1": MetricSpec("F1", "", 3, "max"),
    "events": MetricSpec("Events", "", 0, None),
    "estimate_mae": MetricSpec("Est. MAE", "m"),
    "n": MetricSpec("n", "", 0, None),
    # the fusion's outlier decisions (report/outlier_scores.py): nlos_scores.csv's
    # ``detected`` and ``events`` of the fusion:<method> rows
    "down_weighted": MetricSpec("Down-weighted", "", 0, None),
    "rejected": MetricSpec("Rejected", "", 0, None),
}
