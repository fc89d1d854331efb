"""The INS in the run (issue 12 items 4-5; docs/methods-ins.md, "In the pipeline").

- :func:`ins_pipeline`: when platforms have an IMU and the session has anchors, the chain
  gains ``[ins] modes`` (default the four INS modes of paper 003 Table 1) and ``lsq`` (UWB
  least squares, Table 1's first mode), unless ``[pipeline] positions`` already names an
  INS method or ``[ins] modes = []``. A note says so.
- :func:`ins_navigation`: ``[ins] navigation = "ins"`` replaces the navigation file of
  each platform with an IMU by the INS dead reckoning (IMU + NHC + odometer, no UWB,
  forward filter) started from that file, so that the cooperative fusion (paper 000) and
  the DI stage take their increments from the INS.
- :func:`states_table`: states.csv, the velocity and attitude of every method that
  estimates them, plus rows of method ``reference`` where the reference has a velocity
  or a heading.

A session without IMU passes through all three unchanged (same objects, no states.csv).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pandas as pd

from coopproc.model import STATES_COLUMNS, Session, Trajectory
from coopproc.run.chain import PipelineParams
from coopproc.stages.base import NavStates, PositionProduct
from coopproc.stages.ins.ins_stage import (
    INS_MODES,
    InsParams,
    dead_reckoning,
    ins_platforms,
)

__all__ = ["ins_navigation", "ins_pipeline", "states_table", "with_ins"]


def ins_pipeline(
    params: PipelineParams, session: Session, ins: InsParams
) -> tuple[PipelineParams, list[str]]:
    """The chain with the INS modes added (module docstring) and the notes."""
    imu = ins_platforms(session)
    anchors = any(p.role == "anchor" for p in session.platforms.values())
    if not imu or not anchors or not ins.modes:
        return params, []
    if any(name in INS_MODES for name in params.positions):
        return params, []
    added = [m for m in ("lsq", *ins.modes) if m not in params.positions]
    note = (
        f"{', '.join(imu)} with an IMU and ranges to anchors: {', '.join(added)} added to "
        "[pipeline] positions (paper 003 Table 1; [ins] modes = [] leaves them out)"
    )
    return dataclasses.replace(params, positions=(*params.positions, *added)), [note]


def with_ins(
    session: Session, params: PipelineParams, ins: InsParams
) -> tuple[Session, PipelineParams, list[str]]:
    """:func:`ins_navigation` and :func:`ins_pipeline` together (run_pipeline's one call)."""
    session, notes = ins_navigation(session, ins)
    params, more = ins_pipeline(params, session, ins)
    return session, params, [*notes, *more]


def ins_navigation(session: Session, ins: InsParams) -> tuple[Session, list[str]]:
    """The session with the INS dead reckoning as the navigation of platforms with an
    IMU and a navigation file (``[ins] navigation = "ins"``), and the notes."""
    if ins.navigation != "ins":
        return session, []
    targets = [p for p in ins_platforms(session) if p in session.nav]
    if not targets:
        return session, [
            "[ins] navigation = 'ins': no platform has both an IMU and a navigation file "
            "(the start); the navigation files are used"
        ]
    nav = dict(session.nav)
    notes = []
    for platform in targets:
        nav[platform], note = dead_reckoning(session, platform, ins)
        notes.append(f"navigation of {platform}: {note}")
    return dataclasses.replace(session, nav=nav), notes


def _reference_states(ref: Trajectory, t: np.ndarray) -> pd.DataFrame | None:
    """The reference's velocity and heading at ``t`` (NaN outside it and in its gaps)."""
    if len(ref) < 2 or (ref.vel_enu_mps is None and ref.heading_deg is None):
        return None
    t = t[(t >= ref.time_s[0]) & (t <= ref.time_s[-1])]
    gap = np.isnan(ref.interpolate_within(t)[:, 0])
    values = np.full((t.size, 6), np.nan)
    if ref.vel_enu_mps is not None:
        for i in range(3):
            values[:, i] = np.interp(t, ref.time_s, ref.vel_enu_mps[:, i])
    if ref.heading_deg is not None:
        unwrapped = np.degrees(np.unwrap(np.radians(ref.heading_deg)))
        values[:, 5] = np.mod(np.interp(t, ref.time_s, unwrapped), 360.0)
    values[gap] = np.nan
    frame = pd.DataFrame(values, columns=list(STATES_COLUMNS[3:9]))
    frame.insert(0, "method", "reference")
    frame.insert(0, "platform", ref.platform)
    frame.insert(0, "time", t)
    return frame


def _rows(platform: str, method: str, s: NavStates) -> pd.DataFrame:
    data = np.column_stack([s.vel_enu_mps, s.att_deg, s.sigma_vel_mps, s.sigma_att_deg])
    frame = pd.DataFrame(data, columns=list(STATES_COLUMNS[3:]))
    frame.insert(0, "method", method)
    frame.insert(0, "platform", platform)
    frame.insert(0, "time", s.time_s)
    return frame


def states_table(session: Session, products: Mapping[str, PositionProduct]) -> pd.DataFrame | None:
    """states.csv rows by platform, method, time (None when no method has states); the
    reference rows at the epochs of the platform's first method with states."""
    parts: dict[tuple[str, str], pd.DataFrame] = {}
    for method, product in products.items():
        for platform, states in product.states.items():
            if len(states.time_s):
                parts[platform, method] = _rows(platform, method, states)
    if not parts:
        return None
    for platform in sorted({p for p, _ in parts}):
        ref = session.reference.get(platform)
        first = next(v for (p, _), v in parts.items() if p == platform)
        if ref is not None:
            rows = _reference_states(ref, first["time"].to_numpy(np.float64))
            if rows is not None and len(rows):
                parts[platform, "reference"] = rows
    frame = pd.concat([parts[k] for k in sorted(parts)], ignore_index=True)
    return frame[list(STATES_COLUMNS)]
