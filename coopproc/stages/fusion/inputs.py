"""What a fusion of one range set prepares before its compiled passes, kept for the next.

The self-calibration (:mod:`coopproc.stages.fusion.calibration`) fuses one range set
several times: drift rounds that change only the drift scales, then a final fusion whose
ranges differ from the first only in their sigmas (and, after a platform range-bias
correction, in the range values of that platform). Everything else, the cleaned range
rows, the epochs, the observation structure (:func:`build_observations`: only ``var``
and ``z`` of the range rows change), the recorded slots, the navigation samples and the
observations table's id columns, is the same: :func:`fusion_inputs` prepares it once and
:meth:`FusionInputs.with_ranges` gives the next range set's inputs with new ``var`` /
``z`` arrays and everything else shared (read only: the kernels never write to them).
The values are those a fresh preparation gives, element by element.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.model import FloatArray, Session
from coopproc.stages.fusion.nav_span import covered_rows, epoch_bounds, span_clip
from coopproc.stages.fusion.observations import build_observations, nav_sigma
from coopproc.stages.fusion.output import recorded_slots
from coopproc.stages.fusion.params import FusionParams
from coopproc.stages.shared.data import (
    RangeRows,
    anchor_positions,
    clean_range_rows_indexed,
    epoch_groups,
    id_column,
    nav_points,
    nav_samples,
    range_sigma_default,
    row_sigmas,
)
from coopproc.stages.shared.lsq import robust_lsq_positions

__all__ = ["FusionInputs", "fusion_inputs"]


@dataclass(frozen=True, eq=False)
class FusionInputs:
    """One range set's fusion inputs that do not depend on the drift scales.

    ``obs``: :func:`build_observations`'s arrays; ``source``: each clean range row's row in
    the range table it was prepared from; ``head``: the rows of the first epoch's window
    (the initial state's anchor fix); ``from_id`` / ``to_id``: the observations table's id
    columns.
    """

    session: Session
    params: FusionParams
    output: Literal["ranges", "nav"]
    moving: list[str]
    epochs: FloatArray
    ep_idx: np.ndarray
    obs: dict[str, np.ndarray]
    source: np.ndarray
    finite: np.ndarray  # the range table's finite ranges (the rows kept depend on them)
    head: RangeRows
    x0: FloatArray
    c0: FloatArray
    rec_ptr: np.ndarray
    rec_plat: np.ndarray
    nav: tuple[FloatArray, FloatArray, np.ndarray]
    from_id: pd.api.extensions.ExtensionArray
    to_id: pd.api.extensions.ExtensionArray

    def with_ranges(
        self, ranges: pd.DataFrame, output: Literal["ranges", "nav"] | None = None
    ) -> FusionInputs:
        """The inputs of ``ranges``, a table with the rows (time, from, to, finite range)
        of the one these were prepared from and other sigmas or range values; ``output``
        (default: the same) may differ. Anything else: a fresh :func:`fusion_inputs`."""
        output = self.output if output is None else output
        value = pd.to_numeric(ranges["range"], errors="coerce").to_numpy(np.float64)
        if value.shape != self.finite.shape or not np.array_equal(np.isfinite(value), self.finite):
            return fusion_inputs(self.session, ranges, self.params, output)
        session, params = self.session, self.params
        sigma = row_sigmas(ranges, range_sigma_default(session, params.range_sigma_m))
        sigma = sigma[self.source]
        var = sigma * sigma
        del sigma
        value = value[self.source]
        at = self.obs["at"]
        obs = dict(self.obs)
        obs["var"] = self.obs["var"].copy()
        obs["var"][at] = var
        if not np.array_equal(value, self.obs["z"][at]):
            obs["z"] = self.obs["z"].copy()
            obs["z"][at] = value
        n_head = len(self.head)  # the clean rows are in time order: the head is a prefix
        head = RangeRows(
            self.head.time, value[:n_head].copy(), var[:n_head].copy(), self.head.from_code,
            self.head.to_code, self.head.ids,
        )  # fmt: skip
        del var, value
        x0, c0 = _initial_state(session, head, self.epochs, self.moving, params)
        rec_ptr, rec_plat = self.rec_ptr, self.rec_plat
        if output != self.output:
            rec_ptr, rec_plat = _slots(session, ranges, self.moving, self.epochs, params, output)
        return dataclasses.replace(
            self, output=output, obs=obs, head=head, x0=x0, c0=c0, rec_ptr=rec_ptr,
            rec_plat=rec_plat,
        )  # fmt: skip


def _slots(
    session: Session,
    ranges: pd.DataFrame,
    moving: list[str],
    epochs: FloatArray,
    params: FusionParams,
    output: str,
) -> tuple[np.ndarray, np.ndarray]:
    record_all = output == "nav" or params.epoch_merge_s > 0
    return recorded_slots(session, ranges, moving, epochs, record_all)


def fusion_inputs(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    output: Literal["ranges", "nav"] = "ranges",
) -> FusionInputs:
    """Prepare the fusion of ``ranges`` (see :func:`~coopproc.stages.fusion.fuse.fuse`)."""
    dim = params.dims
    moving = list(session.moving_platforms())
    if not moving:
        raise StageError("fusion: the session has no moving platform")
    for pid in moving:
        if pid not in session.nav or len(session.nav[pid]) < 2:
            raise StageError(f"fusion: platform '{pid}' has no navigation (needs 2+ epochs)")
    anchors = anchor_positions(session)
    value = pd.to_numeric(ranges["range"], errors="coerce") if "range" in ranges else None
    rows, source = clean_range_rows_indexed(
        session, ranges, range_sigma_default(session, params.range_sigma_m)
    )
    # each range only where each of its moving ends has navigation (issue 29: one
    # platform's shorter navigation leaves out its own ranges, not the others' epochs)
    inside = covered_rows(session, rows, moving)
    if not inside.all():  # (a copy of every row only when some are outside)
        at = np.flatnonzero(inside)
        rows, source = rows.take(at), source[at]
        del at
    del inside
    epochs, ep_idx = epoch_groups(rows.time, params.epoch_merge_s)
    if epochs.shape[0] == 0:
        raise StageError(
            "fusion: no range epoch with navigation at every moving end of a range "
            "(each range is outside an end's navigation span, or there is none)"
        )
    k_lo, k_hi = epoch_bounds(session, moving, epochs)
    for p, pid in enumerate(moving):
        if k_lo[p] >= k_hi[p]:
            traj = session.nav[pid]
            raise StageError(
                f"fusion: platform '{pid}' has no range epoch inside its navigation "
                f"({traj.time_s[0]:.3f} .. {traj.time_s[-1]:.3f} s)"
            )
    window = max(params.lsq.epoch_merge_s, 0.0)
    head = rows.take(np.flatnonzero(rows.time <= epochs[0] + window))
    x0, c0 = _initial_state(session, head, epochs, moving, params)
    obs = build_observations(session, rows, ep_idx, epochs, moving, anchors, params)
    from_id, to_id = id_column(rows.ids, rows.from_code), id_column(rows.ids, rows.to_code)
    del rows
    rec_ptr, rec_plat = _slots(session, ranges, moving, epochs, params, output)
    assert value is not None  # clean_range_rows_indexed checked the column
    return FusionInputs(
        session=session,
        params=params,
        output=output,
        moving=moving,
        epochs=epochs,
        ep_idx=ep_idx,
        obs=obs,
        source=source,
        finite=np.isfinite(value.to_numpy(np.float64)),
        head=head,
        x0=x0,
        c0=c0,
        rec_ptr=rec_ptr,
        rec_plat=rec_plat,
        nav=nav_samples(session, moving, dim),
        from_id=from_id,
        to_id=to_id,
    )


def _initial_state(
    session: Session,
    head: RangeRows,
    epochs: FloatArray,
    moving: list[str],
    params: FusionParams,
) -> tuple[FloatArray, FloatArray]:
    """Each platform's navigation at the first epoch; a robust LSQ fix where anchors give
    one. A platform whose navigation starts later: its first sample (its state is carried
    unchanged until it enters, :mod:`~coopproc.stages.fusion.nav_span`), with that
    sample's sigma.

    ``head``: the range rows up to the first epoch plus ``[fusion.lsq] epoch_merge_s``.
    """
    dim = params.dims
    # memory (issue 11): the navigation at the first epoch only, not at every epoch;
    # each platform's at the first epoch clipped to its span (issue 29): the same value
    # where it has navigation then
    start = [span_clip(session, pid, epochs[:1]) for pid in moving]
    nav0 = np.array(
        [nav_points(session, pid, t, range(dim))[0] for pid, t in zip(moving, start, strict=True)]
    )
    x0 = nav0.reshape(-1).copy()
    sig = np.full(x0.shape[0], params.initial_sigma_m)
    for p, pid in enumerate(moving):
        default = params.leader_sigma_m if session.platforms[pid].role == "leader" else None
        sig[p * dim : (p + 1) * dim] = nav_sigma(session, pid, start[p], default or sig[p * dim])[
            0, :dim
        ]
    has_anchor = any(pl.role == "anchor" for pl in session.platforms.values())
    if params.init_from_anchors and has_anchor:
        lsq = dataclasses.replace(params.lsq, dims=dim)
        fixes = robust_lsq_positions(session, head.frame(), lsq)
        for p, pid in enumerate(moving):
            fix = fixes.get(pid)
            if fix is None or session.platforms[pid].role == "leader":
                continue
            # the first fix (at a time inside the platform's span: the head rows are),
            # carried back to the initial state's time by the platform's own DR
            back = session.nav[pid].interpolate(fix.time_s[:1])[0, :dim] - nav0[p]
            x0[p * dim : (p + 1) * dim] = fix.enu_m[0, :dim] - back
            assert fix.sigma_enu_m is not None
            sig[p * dim : (p + 1) * dim] = np.maximum(fix.sigma_enu_m[0, :dim], 1e-3)
    return x0, np.diag(sig * sig)
