"""Single-auxiliary cooperative localization of paper 004: AACOPF, PF, EKF, observability."""

from coopproc.stages.particle.locate import (
    LOCATE_COLUMNS,
    LOCATE_SUMMARY_COLUMNS,
    locate,
    locate_params,
    observability_table,
    with_seed,
)
from coopproc.stages.particle.params import LocateParams

__all__ = [
    "LOCATE_COLUMNS",
    "LOCATE_SUMMARY_COLUMNS",
    "LocateParams",
    "locate",
    "locate_params",
    "observability_table",
    "with_seed",
]
