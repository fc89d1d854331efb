"""Every stage the chain can run, by name: one line per stage.

``[pipeline] ranges`` names methods of the range processors, ``[pipeline] positions``
names position estimators (:mod:`coopproc.run.chain` resolves them into steps). Adding a
method is one module with a :class:`coopproc.stages.base.RangeStage` or
:class:`coopproc.stages.base.PositionStage` and one line here (docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Iterable

from coopproc.stages.anchors import entry as anchors_entry
from coopproc.stages.base import PositionStage, RangeStage
from coopproc.stages.fusion import entry as fusion_entry
from coopproc.stages.gnss.tight_stage import GNSS_STAGES
from coopproc.stages.ins.ins_stage import INS_STAGES
from coopproc.stages.odometry import odo_uwb
from coopproc.stages.ranging import entry as ranging_entry
from coopproc.stages.ranging import median

__all__ = ["POSITION_STAGES", "RANGE_STAGES", "range_stage_of"]

#: Range processors, by stage name.
RANGE_STAGES: dict[str, RangeStage] = {
    s.name: s
    for s in (
        ranging_entry.STAGE,  # rn, di (paper 000)
        median.STAGE,  # median (a model-free baseline; docs/extending.md)
    )
}

#: Position estimators, by stage name.
POSITION_STAGES: dict[str, PositionStage] = {
    s.name: s
    for s in (
        fusion_entry.FUSION,  # cooperative EKF + RTS (papers 002, 003)
        anchors_entry.LSQ,  # robust least squares from anchors (paper 003)
        anchors_entry.LSQ_KF,  # lsq + constant-velocity KF (UWB only)
        anchors_entry.LSQ_RTS,  # lsq + constant-velocity KF + RTS (UWB only, paper 003)
        anchors_entry.RANGE_KF,  # range-by-range constant-velocity EKF (UWB only)
        anchors_entry.RANGE_RTS,  # range_kf + RTS smoother
        odo_uwb.ODO_UWB,  # odometer + UWB EKF (platforms with odo_<ID>.csv)
        odo_uwb.ODO_UWB_RTS,  # odo_uwb + RTS smoother
        *INS_STAGES,  # ins, ins_nhc, ins_rts, ins_nhc_rts (UWB/INS, paper 003 Table 1)
        *GNSS_STAGES,  # gnss, gnss_kf, tight, tight_kf (GPS/UWB, paper 002)
    )
}


def range_stage_of(method: str) -> RangeStage | None:
    """The range processor that produces ``method``, or None."""
    for stage in RANGE_STAGES.values():
        if method in stage.methods:
            return stage
    return None


def method_label(method: str, long: bool = False) -> str:
    """``method``'s short (``DI``) or long (``DI-Based``) name as its range processor
    declares it (:attr:`RangeStage.labels`); the name itself when none does."""
    stage = range_stage_of(method)
    names = stage.labels.get(method) if stage is not None else None
    return method if names is None else names[1 if long else 0]


def declared_labels(methods: Iterable[str]) -> dict[str, str]:
    """The long names of ``methods`` that their range processors declare (run.json
    ``"method_labels"``, which the report shows them by); the others are not listed."""
    return {m: label for m in methods if (label := method_label(m, long=True)) != m}


def nlos_source(methods: Iterable[str]) -> str | None:
    """Of ``methods`` (chain order) that detect NLOS, the one whose decisions fill
    ranges.csv's NLOS columns and head the summary: the first a range processor declares
    primary (:attr:`RangeStage.nlos_primary`), else the first; None for none."""
    methods = tuple(methods)
    return next((m for m in nlos_primary() if m in methods), next(iter(methods), None))


def nlos_primary() -> tuple[str, ...]:
    """Every method a range processor declares primary (:attr:`RangeStage.nlos_primary`),
    in registry order."""
    return tuple(m for stage in RANGE_STAGES.values() for m in stage.nlos_primary)


def primary_method(processed: Iterable[str]) -> str | None:
    """Of the processed range methods (chain order), the one the headline and paper 000's
    figures compare with the observed ranges: the first a range processor declares
    primary, else the last; None for none (run.json ``methods.primary``)."""
    processed = tuple(processed)
    last = processed[-1] if processed else None
    return next((m for m in nlos_primary() if m in processed), last)
