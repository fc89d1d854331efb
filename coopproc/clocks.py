"""The clock offsets of a session's files, as estimated (:mod:`coopproc.checks.clock`).

Typed containers between the estimate and its readers (``validate``, ``run``, run.json);
:class:`coopproc.model.Session` holds one in ``clock``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["ClockReport", "TimeOffset"]


@dataclass(frozen=True)
class TimeOffset:
    """The clock offset of one file, estimated from the data (coopproc.checks.clock).

    ``offset_s``: how far the file's times run ahead of the range clock (navigation:
    against the ranges; reference: against the ranges through its navigation, or against
    its navigation when that one's is not observable); None when it is not observable
    (``why`` says why).
    """

    #: ``[time.offsets]`` key: ``nav.A``, ``ref.A``
    key: str
    platform: str
    #: the file (or MCAP channel) it was read from
    source: str
    offset_s: float | None
    sigma_s: float | None
    #: ranges (navigation) or reference epochs (reference) used
    count: int = 0
    why: str = ""
    #: reference: its offset against its own navigation, s (None for navigation)
    against_nav_s: float | None = None


@dataclass(frozen=True)
class ClockReport:
    """Every file's estimated clock offset, the session clock kept, the corrections."""

    offsets: tuple[TimeOffset, ...]
    #: offset of the session clock kept (the one most files share) against the ranges', s
    kept_s: float
    #: seconds each file's times run ahead of the kept clock, by key, where that exceeds
    #: the bound and 5 sigma (checks.clock; what ``[time] offsets = "estimate"`` subtracts)
    corrections: Mapping[str, float]
    #: what was subtracted on reading, by key ([time] offsets), s
    applied: Mapping[str, float] = field(default_factory=dict)
