"""Each moving platform's navigation span: where the fusion may use and report it (issue 29).

A platform's navigation covers the span from its first to its last sample. The fusion
takes a range only where each of its moving ends has navigation (an anchor is always
there), a leader's own fix only inside the leader's span, and records and reports a
platform only at the epochs inside its span. One platform's shorter navigation so
leaves out its own ranges, never the other platforms' epochs: the epochs are the range
times inside the union of the spans where both ends of a range have navigation.
``coopproc run`` leaves such ranges out of the session before any stage, with a note per
platform (:func:`coopproc.checks.coverage.restrict_to_coverage`, whose rule is stricter:
gaps inside a span too); the fusion's own rule holds for any range table it is given.

Outside its span a platform's state is carried unchanged: the dead-reckoning increment
(:func:`~coopproc.stages.fusion.nav_kernel.nav_at`, ``np.interp``'s end values) is zero
there and no observation involves it, so a platform whose navigation starts after the
first epoch holds its initial state (its navigation at its first sample, with that
sample's sigma, uncorrelated with the others) until it enters, exactly a reset at its
first sample except for the process noise of the epochs before it (a little more
uncertainty, never a wrong mean; see docs/methods-fusion.md). One whose navigation ends
early keeps its last state, which no later observation reads: the others' estimates are
those of a fusion without it from then on.

Spans are intervals and the epochs sorted, so a platform's epochs are one index range
``k_lo[p]:k_hi[p]`` (:func:`epoch_bounds`): no (K, P) mask is formed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray, Session
from coopproc.stages.shared.data import RangeRows

__all__ = ["covered_rows", "epoch_bounds", "nav_spans", "span_clip"]

IntArray = NDArray[np.int64]


def nav_spans(session: Session, moving: Sequence[str]) -> tuple[FloatArray, FloatArray]:
    """First and last navigation time (s) of each of ``moving`` (P,), (P,)."""
    first = np.array([session.nav[p].time_s[0] for p in moving], dtype=np.float64)
    last = np.array([session.nav[p].time_s[-1] for p in moving], dtype=np.float64)
    return first, last


def epoch_bounds(
    session: Session, moving: Sequence[str], epochs: FloatArray
) -> tuple[IntArray, IntArray]:
    """Each platform's epochs inside its navigation span: ``epochs[k_lo[p]:k_hi[p]]``
    (empty when ``k_lo[p] >= k_hi[p]``)."""
    first, last = nav_spans(session, moving)
    k_lo = np.searchsorted(epochs, first, side="left").astype(np.int64)
    k_hi = np.searchsorted(epochs, last, side="right").astype(np.int64)
    return k_lo, k_hi


def span_clip(session: Session, pid: str, times: FloatArray) -> FloatArray:
    """``times`` clipped to ``pid``'s navigation span (unchanged inside it): the times
    whose navigation a state outside the span carries (``np.interp``'s end values)."""
    traj = session.nav[pid]
    return np.clip(times, traj.time_s[0], traj.time_s[-1])


def covered_rows(session: Session, rows: RangeRows, moving: Sequence[str]) -> NDArray[np.bool_]:
    """Whether each range row has navigation at its time at every moving end."""
    first, last = nav_spans(session, moving)
    index = {pid: p for p, pid in enumerate(moving)}
    # per platform id (``rows.ids``): its span; a non-moving end (anchor) is always there
    lo = np.full(len(rows.ids), -np.inf)
    hi = np.full(len(rows.ids), np.inf)
    for i, pid in enumerate(rows.ids):
        p = index.get(pid)
        if p is not None:
            lo[i], hi[i] = first[p], last[p]
    keep = np.ones(len(rows), dtype=bool)
    for codes in (rows.from_code, rows.to_code):
        keep &= (rows.time >= lo[codes]) & (rows.time <= hi[codes])
    return keep
