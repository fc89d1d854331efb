"""Platforms with an odometer in the stage chain: the odometer/UWB methods by default.

When a platform has an odometer (``odo_<ID>.csv``) with a yaw rate (wheel speeds, a
twist, or an IMU beside it) and ranges to fixed anchors, ``odo_uwb`` and ``odo_uwb_rts``
(:mod:`coopproc.stages.odometry.odo_uwb`) are added to ``[pipeline] positions`` unless the
chain already names one of them or ``[odo_uwb] auto = false``; the decision is a note.

A session without odometer files passes through unchanged (the same objects), so its
outputs are those of a run without this module.
"""

from __future__ import annotations

import dataclasses

from coopproc.model import Session
from coopproc.run.chain import PipelineParams
from coopproc.stages.odometry.odo_track import OdoUwbParams

__all__ = ["ODO_METHODS", "odo_pipeline", "odo_platforms"]

#: The estimators added for platforms with an odometer.
ODO_METHODS: tuple[str, ...] = ("odo_uwb", "odo_uwb_rts")


def odo_platforms(session: Session) -> list[str]:
    """The moving platforms whose odometer gives a yaw rate (or that have an IMU) and that
    range to an anchor, in session order."""
    anchors = {p for p, v in session.platforms.items() if v.role == "anchor"}
    if not anchors or not session.odometer:
        return []
    frame = session.ranges.frame
    out = []
    for pid in sorted(session.odometer):
        platform = session.platforms.get(pid)
        if platform is None or platform.role == "anchor":
            continue
        if session.odometer[pid].yaw_rate_radps is None and pid not in session.imu:
            continue
        with_anchor = ((frame["from"] == pid) & frame["to"].isin(anchors)) | (
            (frame["to"] == pid) & frame["from"].isin(anchors)
        )
        if with_anchor.any():
            out.append(pid)
    return out


def odo_pipeline(
    params: PipelineParams, session: Session, odo: OdoUwbParams
) -> tuple[PipelineParams, list[str]]:
    """The chain with the odometer/UWB methods when the session has such platforms, and
    the note saying so (module docstring)."""
    if not odo.auto or any(n in ODO_METHODS for n in params.positions):
        return params, []
    platforms = odo_platforms(session)
    if not platforms:
        return params, []
    note = (
        f"{', '.join(platforms)}: odometer with a yaw rate and ranges to anchors: "
        f"{', '.join(ODO_METHODS)} added to [pipeline] positions ([odo_uwb] auto = false: not)"
    )
    positions = (*params.positions, *ODO_METHODS)
    return dataclasses.replace(params, positions=positions), [note]
