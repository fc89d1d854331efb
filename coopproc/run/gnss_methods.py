"""Platforms with raw GPS observations in the stage chain (issue 13 items 4-5).

When platforms have ``obs_<ID>.*`` files (``Session.gnss``), ``[gnss] methods`` (default
``gnss`` and ``tight``; :mod:`coopproc.stages.gnss.tight_stage`) are added to
``[pipeline] positions`` unless the chain already names one of them or ``[gnss] methods
= []``; the decision is a note. A session without observation files passes through
unchanged (the same objects), so its outputs are those of a run without this module.
"""

from __future__ import annotations

import dataclasses

from coopproc.model import Session
from coopproc.run.chain import PipelineParams
from coopproc.stages.gnss.tight_stage import GNSS_METHODS, GnssParams, gnss_platforms

__all__ = ["gnss_pipeline"]


def gnss_pipeline(
    params: PipelineParams, session: Session, gnss: GnssParams, notes: list[str]
) -> tuple[PipelineParams, list[str]]:
    """The chain with the GPS methods when the session has observations, and ``notes``
    with the note saying so appended."""
    if not session.gnss or not gnss.methods:
        return params, notes
    if any(n in GNSS_METHODS for n in params.positions):
        return params, notes
    platforms = gnss_platforms(session)
    if not platforms:
        return params, notes
    added = [m for m in gnss.methods if m not in params.positions]
    note = (
        f"{', '.join(platforms)} with GPS observations: {', '.join(added)} added to "
        "[pipeline] positions (paper 002; [gnss] methods = [] leaves them out)"
    )
    return dataclasses.replace(params, positions=(*params.positions, *added)), [*notes, note]
