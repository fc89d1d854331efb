"""The position estimators as the chain sees them: registry entries ``fusion`` and ``lsq``.

- ``fusion``: the centralized cooperative EKF with IGG-III and RTS smoothing, self-
  calibrated (:func:`coopproc.stages.fusion.calibration.calibrated_fuse`), run once per
  range set; its positions.csv method is the range set's name (DATA.md: ``observed``,
  ``rn``, ``di``). The processed sets take the observed fusion's per-pair sigmas as floor.
  On the observed ranges it also gives the cooperative solution the ranging stage needs.
- ``lsq``: robust least squares from fixed anchors (paper 003 sec. 2.2,
  :func:`coopproc.stages.fusion.lsq.robust_lsq_positions`), epoch by epoch; method
  ``lsq`` on the observed ranges, ``lsq_<set>`` on a processed set.
"""

from __future__ import annotations

from coopproc.errors import StageError
from coopproc.model import Session
from coopproc.stages.base import PositionInput, PositionProduct, PositionStage
from coopproc.stages.fusion.calibration import calibrated_fuse
from coopproc.stages.fusion.fuse import FusionParams
from coopproc.stages.fusion.lsq import LsqParams, robust_lsq_positions

__all__ = ["FUSION", "LSQ", "fusion_stage", "lsq_stage"]


def fusion_stage(inp: PositionInput, params: FusionParams) -> PositionProduct:
    """Fuse one range set (see the module docstring)."""
    floor = None
    if inp.observed is not None and inp.observed.calibration is not None:
        floor = inp.observed.calibration.pair_sigma_m
    fused, cal = calibrated_fuse(
        inp.session,
        inp.ranges,
        params,
        output=inp.output,
        label=inp.range_set,
        sigma_floor=floor,
        smoothed_sigma=False,  # positions.csv and the ranging stage take positions only
    )
    cp = None
    if inp.want_cp:
        at_ranges = fused
        if inp.output != "ranges":
            at_ranges, _ = calibrated_fuse(
                inp.session, inp.ranges, params, output="ranges", smoothed_sigma=False
            )
        cp = (at_ranges.forward, at_ranges.smoothed)
    return PositionProduct(positions=fused.smoothed, cp=cp, calibration=cal, notes=cal.notes)


def lsq_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """Robust least-squares fixes of every platform ranging to enough anchors."""
    return PositionProduct(positions=robust_lsq_positions(inp.session, inp.ranges, params))


def _has_anchors(session: Session) -> None:
    if not any(p.role == "anchor" for p in session.platforms.values()):
        raise StageError(
            "lsq: the session has no anchors (platforms with role 'anchor'); robust least "
            "squares positions platforms from ranges to fixed anchors"
        )


FUSION = PositionStage(
    name="fusion",
    params_type=FusionParams,
    section="fusion",
    run=fusion_stage,
    help="cooperative EKF + IGG-III + RTS smoother over all platforms (papers 002, 003), "
    "once per range set; method = the range set's name",
    named_by_range_set=True,
    provides_cp=True,
    needs_observed=True,
)

LSQ = PositionStage(
    name="lsq",
    params_type=LsqParams,
    section="fusion.lsq",
    run=lsq_stage,
    help="robust least squares from fixed anchors, epoch by epoch (paper 003 sec. 2.2); "
    "method lsq (observed ranges) or lsq_<set>",
    check=_has_anchors,
)
