"""The UWB-only methods from fixed anchors as the chain sees them: registry entries ``lsq``,
``lsq_kf``, ``lsq_rts``, ``range_kf``, ``range_rts``.

- ``lsq``: robust least squares from fixed anchors (paper 003 sec. 2.2,
  :func:`coopproc.stages.shared.lsq.robust_lsq_positions`), epoch by epoch; method
  ``lsq`` on the observed ranges, ``lsq_<set>`` on a processed set.
- ``lsq_kf`` / ``lsq_rts``: the same fixes through a constant-velocity Kalman filter
  (causal) / and its RTS smoother (:mod:`coopproc.stages.anchors.uwb_kf`); methods
  ``lsq_kf``, ``lsq_rts`` (``lsq_kf_<set>``, ``lsq_rts_<set>``).
- ``range_kf`` / ``range_rts``: each range to an anchor straight into a constant-velocity
  EKF (:mod:`coopproc.stages.anchors.range_kf`) / and its RTS smoother.

They are UWB-only (``uwb_only``): they position a ``tag`` (no navigation of its own).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from coopproc.errors import StageError
from coopproc.model import Session, Trajectory
from coopproc.stages.anchors.anchor_lsq import AnchorSolution, anchor_fixes
from coopproc.stages.anchors.range_kf import range_kf_positions
from coopproc.stages.anchors.uwb_kf import uwb_kf_positions
from coopproc.stages.base import PositionInput, PositionProduct, PositionStage
from coopproc.stages.shared.lsq import LsqParams, fixes_trajectory

__all__ = ["LSQ", "LSQ_KF", "LSQ_RTS", "RANGE_KF", "RANGE_RTS", "lsq_stage"]


def _product(
    inp: PositionInput,
    positions: Mapping[str, Trajectory],
    solution: AnchorSolution | None = None,
    name: str = "lsq",
) -> PositionProduct:
    """The positions, with a note for each tag that got none (a tag has nothing else),
    the fixes' notes and their lsq_quality.csv rows (method: the ``lsq`` of the set)."""
    missing = [
        p
        for p in inp.session.platform_ids
        if inp.session.platforms[p].role == "tag" and p not in positions
    ]
    notes = tuple(
        f"tag {p}: no {inp.range_set} fix (never ranged to enough anchors in one round; "
        "with anchors polled one at a time, [fusion.lsq] round_max_s must span one "
        "polling round; range_rts needs no simultaneous ranges); it has no position"
        for p in missing
    )
    if solution is None:
        return PositionProduct(positions=positions, notes=notes)
    method = LSQ.method(inp.range_set)
    notes += tuple(f"{name} ({inp.range_set}): {note}" for note in solution.notes)
    quality = solution.quality.assign(method=method)
    return PositionProduct(positions=positions, notes=notes, lsq_quality=quality)


def lsq_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """Robust least-squares fixes of every platform ranging to enough anchors."""
    solution = anchor_fixes(inp.session, inp.ranges, params)
    positions = {p: fixes_trajectory(p, f, params.robust) for p, f in solution.fixes.items()}
    return _product(inp, positions, solution)


def lsq_kf_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """The fixes through the constant-velocity Kalman filter (causal)."""
    solution = anchor_fixes(inp.session, inp.ranges, params)
    return _product(inp, uwb_kf_positions(solution.fixes, params, smooth=False), solution)


def lsq_rts_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """The fixes through the constant-velocity Kalman filter and the RTS smoother."""
    solution = anchor_fixes(inp.session, inp.ranges, params)
    return _product(inp, uwb_kf_positions(solution.fixes, params, smooth=True), solution)


def range_kf_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """The ranges through the tightly coupled constant-velocity EKF (causal)."""
    return _product(inp, range_kf_positions(inp.session, inp.ranges, params, smooth=False))


def range_rts_stage(inp: PositionInput, params: LsqParams) -> PositionProduct:
    """The tightly coupled EKF and its RTS smoother."""
    return _product(inp, range_kf_positions(inp.session, inp.ranges, params, smooth=True))


def _has_anchors(session: Session) -> None:
    if not any(p.role == "anchor" for p in session.platforms.values()):
        raise StageError(
            "lsq: the session has no anchors (platforms with role 'anchor'); robust least "
            "squares positions platforms from ranges to fixed anchors"
        )


def _anchor_stage(
    name: str, run: Callable[[PositionInput, Any], PositionProduct], help: str
) -> PositionStage:
    """A UWB-only estimator from fixed anchors: ``[fusion.lsq]`` parameters, refused by a
    session without anchors, positions tags too."""
    return PositionStage(
        name=name,
        params_type=LsqParams,
        section="fusion.lsq",
        run=run,
        help=help,
        check=_has_anchors,
        uwb_only=True,
        requires=frozenset({"anchors"}),
    )


LSQ = _anchor_stage(
    "lsq",
    lsq_stage,
    "robust least squares from fixed anchors, epoch by epoch (paper 003 sec. 2.2); "
    "method lsq (observed ranges) or lsq_<set>",
)
LSQ_KF = _anchor_stage(
    "lsq_kf",
    lsq_kf_stage,
    "the lsq fixes through a constant-velocity Kalman filter with IGG-III (causal); "
    "method lsq_kf or lsq_kf_<set>",
)
LSQ_RTS = _anchor_stage(
    "lsq_rts",
    lsq_rts_stage,
    "the lsq_kf filter followed by the RTS smoother (paper 003 sec. 2.8); method "
    "lsq_rts or lsq_rts_<set>",
)
RANGE_KF = _anchor_stage(
    "range_kf",
    range_kf_stage,
    "each range to an anchor straight into a constant-velocity EKF with IGG-III "
    "(tightly coupled, no simultaneous ranges needed; causal); method range_kf",
)
RANGE_RTS = _anchor_stage(
    "range_rts",
    range_rts_stage,
    "the range_kf filter followed by the RTS smoother; method range_rts",
)
