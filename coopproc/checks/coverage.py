"""Does each platform's navigation cover the ranges it takes part in?

A range can only be processed where the navigation of both its ends gives a position.
The one rule is :meth:`coopproc.model.Trajectory.interpolate_within` (gaps longer than
:func:`coopproc.model.gap_limit_s`, 2.5 times the median interval): a platform covers a
time when that method gives a position there, i.e. inside its navigation's span and not
inside a gap. Anchors (fixed position) and platforms without navigation (tags) always
cover.

- :func:`coverage_warnings`: what ``coopproc validate`` warns about, per platform: gaps,
  navigation starting late or ending early relative to the ranges, and how many ranges
  it does not cover;
- :func:`restrict_to_coverage`: the session without the ranges that an end's navigation
  does not cover, with one note per platform affected (``coopproc run``);
- :func:`nav_gap_spans`: where each platform's navigation is missing (run.json
  ``nav_gaps``, which the figures shade as "navigation gap", not as a UWB outage);
- :func:`prepare_run`: everything ``coopproc run`` (and ``coopproc batch``) checks and
  notes before the stage chain.

Times in messages are seconds from the session start (:func:`session_start_s`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import InputError
from coopproc.model import GAP_FACTOR, FloatArray, RangeTable, Session

__all__ = [
    "NavCoverage",
    "coverage_warnings",
    "nav_coverage",
    "nav_gap_spans",
    "prepare_run",
    "restrict_to_coverage",
    "session_start_s",
]

#: Gaps listed one by one in a message; more are summarized.
_MAX_LISTED = 5


@dataclass(frozen=True, eq=False)
class NavCoverage:
    """How one platform's navigation covers the ranges of the pairs it belongs to."""

    platform: str
    start_s: float
    end_s: float
    #: The gap rule: intervals longer than this are gaps, s.
    limit_s: float
    #: (k, 2) start and end of each gap, s (session time base).
    gaps_s: FloatArray
    #: Rows of ``session.ranges.frame`` of the pairs with this platform.
    rows: NDArray[np.bool_]
    #: Of those rows, the ones its navigation does not cover.
    uncovered: NDArray[np.bool_]
    before: int
    after: int
    #: Uncovered ranges inside each gap, (k,).
    in_gap: NDArray[np.int64]

    @property
    def n_uncovered(self) -> int:
        return int(self.uncovered.sum())


def session_start_s(session: Session) -> float:
    """The session start: the first navigation or range epoch, s."""
    times = [float(session.ranges.frame["time"].min())] if len(session.ranges) else []
    times += [traj.span_s[0] for traj in session.nav.values() if len(traj)]
    return min(times) if times else 0.0


def nav_coverage(session: Session) -> dict[str, NavCoverage]:
    """The coverage of every non-anchor platform with navigation, by id."""
    frame = session.ranges.frame
    times = frame["time"].to_numpy(dtype=np.float64)
    ids, first, second = session.ranges.id_codes  # integer codes, no string compares
    out = {}
    for pid in session.platform_ids:
        traj = session.nav.get(pid)
        if session.platforms[pid].role == "anchor" or traj is None or len(traj) == 0:
            continue
        at = int(np.searchsorted(ids, pid))
        if at < ids.shape[0] and ids[at] == pid:
            rows = (first == at) | (second == at)
        else:
            rows = np.zeros(times.shape[0], dtype=bool)
        t = times[rows]
        uncovered = np.zeros(times.shape[0], dtype=bool)
        uncovered[rows] = ~traj.covered(t)
        start, end = traj.span_s
        gaps = traj.gaps_s() if len(traj) > 1 else np.empty((0, 2))
        tu = times[uncovered]
        inside = tu[(tu >= start) & (tu <= end)]
        k = np.searchsorted(gaps[:, 0], inside, side="right") - 1
        in_gap = np.bincount(k[k >= 0], minlength=gaps.shape[0]).astype(np.int64)
        out[pid] = NavCoverage(
            platform=pid,
            start_s=start,
            end_s=end,
            limit_s=traj.gap_limit_s(),
            gaps_s=gaps,
            rows=rows,
            uncovered=uncovered,
            before=int((tu < start).sum()),
            after=int((tu > end).sum()),
            in_gap=in_gap,
        )
    return out


def nav_gap_spans(session: Session) -> dict[str, FloatArray]:
    """(k, 2) start and end (session time base) of every stretch in which a platform's
    navigation gives no position while ranges were taken: its gaps (the rule of
    :meth:`~coopproc.model.Trajectory.gaps_s`) and, when longer than its gap limit, the
    stretch from the run's start (its first range or navigation epoch) to its first epoch
    and from its last epoch to the run's end. Only the platforms with such a stretch
    (anchors and tags have none); the ranges in them are the ones
    :func:`restrict_to_coverage` leaves out, so the figures' UWB outages there are
    navigation gaps (``coopproc run`` records them in run.json
    ``nav_gaps`` before it lets go of the samples)."""
    if not len(session.ranges):
        return {}
    times = session.ranges.frame["time"].to_numpy(dtype=np.float64)
    spans = [traj.span_s for traj in session.nav.values() if len(traj)]
    # the run's span (the figures' bounds): the ranges' and every navigation's
    first = min([float(np.nanmin(times)), *(a for a, _ in spans)])
    last = max([float(np.nanmax(times)), *(b for _, b in spans)])
    out = {}
    for pid in session.platform_ids:
        traj = session.nav.get(pid)
        if session.platforms[pid].role == "anchor" or traj is None or len(traj) < 2:
            continue
        start, end = traj.span_s
        limit = traj.gap_limit_s()
        parts = [traj.gaps_s()]
        if start - first > limit:
            parts.insert(0, np.array([[first, start]]))
        if last - end > limit:
            parts.append(np.array([[end, last]]))
        found = np.concatenate(parts).astype(np.float64).reshape(-1, 2)
        if found.shape[0]:
            out[pid] = found
    return out


def coverage_warnings(session: Session) -> list[str]:
    """What ``coopproc validate`` warns about: per platform, its navigation gaps, a start
    after the first range or an end before the last, and the ranges it does not cover.

    Times are seconds from :func:`session_start_s`. Empty when every platform's
    navigation covers the ranges and has no gap.
    """
    if not len(session.ranges):
        return []
    t0 = session_start_s(session)
    times = session.ranges.frame["time"].to_numpy(dtype=np.float64)
    first, last = float(times.min()), float(times.max())
    out = []
    for pid, cov in nav_coverage(session).items():
        durations = cov.gaps_s[:, 1] - cov.gaps_s[:, 0]
        for (a, b), d in list(zip(cov.gaps_s, durations, strict=True))[:_MAX_LISTED]:
            out.append(
                f"{pid}: navigation gap {a - t0:.1f}-{b - t0:.1f} s ({d:.1f} s; gaps are "
                f"intervals over {cov.limit_s:.3f} s, {GAP_FACTOR} x the median interval)"
            )
        if durations.size > _MAX_LISTED:
            more = durations[_MAX_LISTED:]
            out.append(
                f"{pid}: {more.size} more navigation gaps, {more.sum():.1f} s in all, "
                f"the longest {more.max():.1f} s"
            )
        if cov.start_s > first:
            out.append(
                f"{pid}: navigation starts at {cov.start_s - t0:.1f} s, "
                f"{cov.start_s - first:.1f} s after the first range ({first - t0:.1f} s)"
            )
        if cov.end_s < last:
            out.append(
                f"{pid}: navigation ends at {cov.end_s - t0:.1f} s, "
                f"{last - cov.end_s:.1f} s before the last range ({last - t0:.1f} s)"
            )
        if cov.n_uncovered:
            parts = _counts(cov, t0, spans=False)
            out.append(
                f"{pid}: {cov.n_uncovered} of {int(cov.rows.sum())} ranges of pairs with "
                f"{pid} are not covered by its navigation ({parts}); coopproc run leaves "
                "them out"
            )
    return out


def _counts(cov: NavCoverage, t0: float, *, spans: bool) -> str:
    """``58 after its navigation ends at 540.0 s, 60 in its gap 120.0-180.0 s``."""
    parts = []
    if cov.before:
        at = f" at {cov.start_s - t0:.1f} s" if spans else ""
        parts.append(f"{cov.before} before its navigation starts{at}")
    if cov.after:
        at = f" at {cov.end_s - t0:.1f} s" if spans else ""
        parts.append(f"{cov.after} after its navigation ends{at}")
    hit = np.flatnonzero(cov.in_gap)
    if hit.size and not spans:
        parts.append(f"{int(cov.in_gap.sum())} inside {hit.size} gap{'s' * (hit.size > 1)}")
    elif hit.size:
        listed = [
            f"{cov.in_gap[k]} in its gap {cov.gaps_s[k, 0] - t0:.1f}-{cov.gaps_s[k, 1] - t0:.1f} s"
            for k in hit[:_MAX_LISTED]
        ]
        if hit.size > _MAX_LISTED:
            rest = hit[_MAX_LISTED:]
            listed.append(f"{int(cov.in_gap[rest].sum())} in {rest.size} more gaps")
        parts.extend(listed)
    return ", ".join(parts)


def restrict_to_coverage(session: Session) -> tuple[Session, list[str]]:
    """The session without the ranges that an end's navigation does not cover.

    Returns the new session (its ``notes`` extended) and one note per platform whose
    navigation left ranges out, naming how many and which time spans. A session whose
    navigation covers every range is returned as it is (the same object) with no note.
    Raises InputError when no range is left.
    """
    coverage = nav_coverage(session)
    drop = np.zeros(len(session.ranges), dtype=bool)
    for cov in coverage.values():
        drop |= cov.uncovered
    if not drop.any():
        return session, []
    t0 = session_start_s(session)
    notes = [
        f"excluded {cov.n_uncovered} ranges of pairs with {pid}, not covered by its "
        f"navigation: {_counts(cov, t0, spans=True)} (times from the session start {t0:.3f})"
        for pid, cov in coverage.items()
        if cov.n_uncovered
    ]
    if drop.all():
        raise InputError(
            session.ranges.source or session.root,
            "no range is covered by the navigation of both its ends; "
            + "; ".join(notes).replace("excluded", "would exclude"),
        )
    frame = session.ranges.frame[~drop].reset_index(drop=True)
    ids, first, second = session.ranges.id_codes
    first, second = first[~drop], second[~drop]
    present = np.bincount(np.concatenate([first, second]), minlength=ids.shape[0]) > 0
    code = np.cumsum(present) - 1  # the ids left, renumbered in their sorted order
    codes = (ids[present], code[first], code[second])
    ranges = RangeTable.with_id_codes(frame, session.ranges.source, codes)
    restricted = dataclasses.replace(session, ranges=ranges, notes=(*session.notes, *notes))
    return restricted, notes


def prepare_run(session: Session) -> tuple[Session, list[str]]:
    """What ``coopproc run`` does to a session before the stage chain.

    Estimates the clock offsets (:func:`coopproc.checks.clock.prepared`; applied with
    ``[time] offsets = "estimate"``) and notes those off the session clock, leaves out
    the ranges the navigation does not cover
    (:func:`restrict_to_coverage`) and checks each platform's navigation frame
    (:func:`coopproc.checks.framecheck.frame_notes`). Returns the session (with its
    ``clock`` report) and the new notes, which are also appended to
    its ``notes`` (and so reach run.json). Tags are processed by the run
    (:mod:`coopproc.run.tags`).
    """
    from coopproc.checks.clock import clock_lines, prepared
    from coopproc.checks.framecheck import frame_notes

    session = prepared(session)  # before the ranges are restricted
    warnings, clock_notes = clock_lines(session, session.clock)
    session = dataclasses.replace(session, notes=(*session.notes, *warnings, *clock_notes))
    session, notes = restrict_to_coverage(session)
    notes = [*warnings, *clock_notes, *notes]
    frame = frame_notes(session)
    if frame:
        session = dataclasses.replace(session, notes=(*session.notes, *frame))
    return session, [*notes, *frame]
