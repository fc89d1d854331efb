"""Clock offsets between a session's files: found, measured, reported and applied.

A navigation file logged in GPS time against ranges logged in UTC is 18 s off; a file in
local time is whole hours off; a logger's latency is tens of milliseconds. Nothing in
the times themselves shows it (the time-base checks, :mod:`coopproc.io.timebase`, see
only units and bases), but the data do: a range follows the distance its two ends'
navigation gives only at the right offset. This module estimates, for each platform,

- the offset of its navigation against the range clock, from the ranges
  (:mod:`coopproc.checks.clock_fit`: cross-correlation of the range rate with the
  navigation's distance rate, then Gauss-Newton on the ranges with a bias per pair and
  block, Huber weights, the 1-sigma from the residuals and the slope, inflated for
  correlated residuals);
- the offset of its reference against its navigation (:mod:`coopproc.checks.clock_ref`:
  the same on the positions), and through it against the range clock.

Anchors have no clock (their position is fixed); tags (no navigation) none that matters.

**Not observable**: a platform whose navigation moves less than :data:`MIN_SLOPE_MPS`
along its lines of sight (RMS: a 1 s offset changes its distances by less than 3 cm),
with fewer than :data:`MIN_COUNT` ranges, or whose 1-sigma exceeds :data:`MAX_SIGMA_S`,
gets "offset not observable" and no number. A common offset of every navigation is seen
only through the distances' changes (a rigid formation shows none); lags beyond the
data's span, or where less than half of the ranges (or 30 s) overlap, are not searched:
a whole-hour time zone is found only in a session longer than 2 hours.

**Reported** (``coopproc validate``, ``coopproc run``): the files whose times run ahead
of (or behind) the session clock by more than :data:`BOUND_S` and 5 sigma (below 1 s,
only those measured to :data:`REPORT_SIGMA_S`: the estimates of weakly observable
formations are biased by the navigation's errors beyond their 1-sigma). The session
clock kept is the one most files share (the ranges' on a tie); the ranges are the odd
one out when every navigation is off by the same amount. The likely cause is named
(:func:`likely_cause`: 18 s leap seconds, whole hours, a unit slip x1000, a latency).

**Applied** on request: ``[time] offsets = "estimate"`` subtracts the reported
corrections (:func:`prepared`, called by ``validate`` and before ``run``'s chain);
``[time.offsets]`` constants are subtracted by the reader (:mod:`coopproc.io.session`)
before the time checks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from coopproc.checks.clock_fit import (
    NEAR_LAG_S,
    PEAK_STEP_S,
    SEARCH_STEP_S,
    PairData,
    common_lag,
    platform_lag,
)
from coopproc.checks.clock_ref import reference_offset
from coopproc.checks.clock_refine import BLOCKS_S, refine
from coopproc.checks.clock_words import BOUND_S, clock_facts, clock_lines, likely_cause, name_of
from coopproc.clocks import ClockReport, TimeOffset
from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, RangeTable, Session, Trajectory, pair_members

__all__ = [
    "BOUND_S",
    "apply_corrections",
    "apply_estimates",
    "clock_facts",
    "clock_lines",
    "estimate_clock",
    "likely_cause",
    "prepared",
]

#: Below 1 s, only offsets measured to this 1-sigma are reported (:func:`_reported`), s.
REPORT_SIGMA_S = 0.025
#: Observability: line-of-sight speed, RMS within the bias blocks, m/s (see above).
MIN_SLOPE_MPS = 0.03
#: Observability: ranges of the platform.
MIN_COUNT = 20
#: Observability: largest robust RMS of the ranges against the navigation's distances at
#: the offset found, m (simulated sessions: 0.02-0.2; plaza2's dead reckoning: 11).
MAX_MISFIT_M = 1.0
#: Observability: largest move of the refinement from the coarse estimate, s.
MAX_MOVE_S = 2.0
#: Observability: largest 1-sigma of an estimate worth a number, s.
MAX_SIGMA_S = 0.5
#: Refinement on at most this many ranges (whole windows, evenly spread): the offset is
#: constant, so a day's 4 million ranges add little that 1 % of them do not show.
MAX_RANGES = 20_000
_WINDOW_S = 600.0


def _positions(session: Session) -> dict[str, Trajectory | FloatArray]:
    out: dict[str, Trajectory | FloatArray] = {}
    for pid, platform in session.platforms.items():
        if platform.role == "anchor" and platform.position_enu_m is not None:
            out[pid] = np.asarray(platform.position_enu_m, dtype=np.float64)
        elif pid in session.nav and len(session.nav[pid]) >= 4:
            out[pid] = session.nav[pid]
    return out


def _pairs(session: Session, positions: Mapping[str, object]) -> list[PairData]:
    frame = session.ranges.frame
    times = frame["time"].to_numpy(dtype=np.float64)
    values = frame["range"].to_numpy(dtype=np.float64)
    out = []
    for name, rows in session.ranges.pair_index.items():
        a, b = pair_members(name)
        if a not in positions or b not in positions or rows.shape[0] < 4:
            continue
        if not isinstance(positions[a], Trajectory) and not isinstance(positions[b], Trajectory):
            continue
        t, r = times[rows], values[rows]
        ok = np.isfinite(t) & np.isfinite(r)
        out.append(PairData(a, b, t[ok], r[ok]))
    return out


def _subset(pairs: list[PairData]) -> list[PairData]:
    """At most :data:`MAX_RANGES` ranges: whole windows of 600 s spread over the session."""
    total = sum(p.time_s.shape[0] for p in pairs)
    if total <= MAX_RANGES:
        return pairs
    lo = min(float(p.time_s[0]) for p in pairs)
    hi = max(float(p.time_s[-1]) for p in pairs)
    keep = max(1, int(np.ceil((hi - lo) / _WINDOW_S * MAX_RANGES / total)))
    starts = np.linspace(lo, hi - _WINDOW_S, keep)
    out = []
    for p in pairs:
        k = np.searchsorted(starts, p.time_s, side="right") - 1
        sel = (k >= 0) & (p.time_s - starts[np.maximum(k, 0)] < _WINDOW_S)
        if sel.sum() >= 4:
            out.append(PairData(p.a, p.b, p.time_s[sel], p.range_m[sel]))
    return out


def estimate_clock(session: Session) -> ClockReport:
    """Every platform's navigation and reference offset (module docstring)."""
    positions = _positions(session)
    pairs = _subset(_pairs(session, positions))
    moving = sorted(p for p, v in positions.items() if isinstance(v, Trajectory))
    offsets: list[TimeOffset] = []
    nav_fit: dict[str, tuple[float, float]] = {}
    counts = {pid: sum(p.time_s.shape[0] for p in pairs if pid in (p.a, p.b)) for pid in moving}
    free = [pid for pid in moving if counts[pid] >= MIN_COUNT]
    if free:
        peak = common_lag(pairs, positions)
        common = peak.lag_s if peak is not None else 0.0
        start = dict.fromkeys(free, common)
        unseen: set[str] = set()  # no cross-correlation peak: under 30 s of overlap
        near = np.arange(-NEAR_LAG_S, NEAR_LAG_S + SEARCH_STEP_S / 2, SEARCH_STEP_S)
        around = [common + near] if abs(common) < NEAR_LAG_S else [common + near, near]
        candidates = np.unique(np.concatenate(around))
        for pid in free:  # one sweep: each alone, the others at their estimate so far
            found = platform_lag(pid, pairs, positions, start, candidates)
            if found is None and peak is None:
                unseen.add(pid)
            if found is not None:  # then finer steps around the best
                fine = found.lag_s + np.arange(-1.5, 1.5 + 1e-9, PEAK_STEP_S)
                found = platform_lag(pid, pairs, positions, start, fine) or found
                start[pid] = found.lag_s
        coarse = dict(start)
        fits = []
        for block in BLOCKS_S:  # each from the last one's offsets: a few iterations
            fits.append(refine(pairs, positions, start, free, block))
            start = {**start, **fits[-1].offset_s}
        fit = min(fits, key=lambda f: float(np.mean([f.sigma_s[p] for p in free])))
        misfit = _misfit(pairs, positions, {**start, **fit.offset_s}, free)
    for pid in sorted(session.nav):
        source = session.nav[pid].source
        key = f"nav.{pid}"
        if pid not in free:
            why = (
                "no ranges to platforms with a position"
                if counts.get(pid, 0) == 0
                else f"only {counts.get(pid, 0)} ranges (at least {MIN_COUNT} needed)"
            )
            offsets.append(TimeOffset(key, pid, source, None, None, counts.get(pid, 0), why))
            continue
        slope, sigma = fit.slope_mps[pid], fit.sigma_s[pid]
        why = ""
        if slope < MIN_SLOPE_MPS:
            why = (
                f"its navigation moves {slope:.3f} m/s along its lines of sight, RMS; "
                f"at least {MIN_SLOPE_MPS} m/s needed"
            )
        elif not sigma <= MAX_SIGMA_S:
            why = f"1-sigma {sigma:.2f} s (more than {MAX_SIGMA_S} s)"
        elif misfit[pid] > MAX_MISFIT_M:
            why = (
                f"its navigation does not follow its ranges ({misfit[pid]:.2f} m robust RMS "
                "at the best offset: a frame of its own, or drift)"
            )
        elif pid in unseen:
            why = "under 30 s of its ranges and navigation overlap at any lag"
        elif abs(fit.offset_s[pid] - coarse[pid]) > MAX_MOVE_S:
            why = (
                f"the refinement went {fit.offset_s[pid] - coarse[pid]:+.1f} s from the "
                f"cross-correlation's {coarse[pid]:+.1f} s"
            )
        if why:
            offsets.append(TimeOffset(key, pid, source, None, None, fit.count[pid], why))
        else:
            nav_fit[pid] = (fit.offset_s[pid], sigma)
            offsets.append(TimeOffset(key, pid, source, fit.offset_s[pid], sigma, fit.count[pid]))
    for pid in sorted(session.reference):
        offsets.append(_reference(session, pid, nav_fit))
    kept, corrections = _corrections(offsets)
    return ClockReport(tuple(offsets), kept, corrections)


def _misfit(
    pairs: list[PairData],
    positions: Mapping[str, Trajectory | FloatArray],
    offsets: Mapping[str, float],
    free: list[str],
) -> dict[str, float]:
    """Per platform, the median over its pairs of the robust RMS (1.4826 MAD) of the
    ranges less the navigation's distances at ``offsets``, one bias per pair."""
    spread: dict[str, list[float]] = {pid: [] for pid in free}
    for p in pairs:
        ends = []
        for pid in (p.a, p.b):
            v = positions[pid]
            ends.append(
                v.interpolate(p.time_s + offsets.get(pid, 0.0)) if isinstance(v, Trajectory) else v
            )
        r = p.range_m - slant_ranges(ends[0] - ends[1])
        r = r[np.isfinite(r)]
        if r.size < 4:
            continue
        mad = 1.4826 * float(np.median(np.abs(r - np.median(r))))
        for pid in (p.a, p.b):
            if pid in spread:
                spread[pid].append(mad)
    return {pid: float(np.median(v)) if v else 0.0 for pid, v in spread.items()}


def _reference(
    session: Session, pid: str, nav_fit: Mapping[str, tuple[float, float]]
) -> TimeOffset:
    ref = session.reference[pid]
    key = f"ref.{pid}"
    nav = session.nav.get(pid)
    if nav is None:
        return TimeOffset(key, pid, ref.source, None, None, 0, "no navigation beside it")
    fit = reference_offset(nav, ref)
    if fit is None:
        why = "does not overlap its navigation by 30 s"
        return TimeOffset(key, pid, ref.source, None, None, 0, why)
    if fit.slope_mps < MIN_SLOPE_MPS:
        why = f"its navigation moves {fit.slope_mps:.3f} m/s, RMS"
        return TimeOffset(key, pid, ref.source, None, None, fit.count, why)
    if not fit.sigma_s <= MAX_SIGMA_S:
        why = f"1-sigma {fit.sigma_s:.2f} s (more than {MAX_SIGMA_S} s)"
        return TimeOffset(key, pid, ref.source, None, None, fit.count, why)
    nav_offset, nav_sigma = nav_fit.get(pid, (None, None))
    if nav_offset is None or nav_sigma is None:  # against its navigation only
        return TimeOffset(
            key, pid, ref.source, None, None, fit.count,
            "its navigation's is not observable", against_nav_s=fit.offset_s,
        )  # fmt: skip
    total = nav_offset + fit.offset_s
    sigma = float(np.hypot(nav_sigma, fit.sigma_s))
    return TimeOffset(key, pid, ref.source, total, sigma, fit.count, against_nav_s=fit.offset_s)


def _corrections(offsets: list[TimeOffset]) -> tuple[float, dict[str, float]]:
    """The kept clock (the offset most files share, the ranges' on a tie) and the
    corrections of the files off it as :func:`_reported` says."""
    known: list[tuple[str, float, float]] = [("ranges", 0.0, 0.0)]
    known += [(o.key, o.offset_s, o.sigma_s or 0.0) for o in offsets if o.offset_s is not None]
    best, best_group = 0.0, [known[0]]
    for _, value, sigma in known:
        group = [
            k
            for k in known
            if abs(k[1] - value) <= max(BOUND_S, 3.0 * float(np.hypot(k[2], sigma)))
        ]
        has_ranges = any(k[0] == "ranges" for k in group)
        better = len(group) > len(best_group) or (
            len(group) == len(best_group)
            and has_ranges
            and not any(k[0] == "ranges" for k in best_group)
        )
        if better:
            best_group = group
            if has_ranges:
                best = 0.0
            else:
                weights = np.array([1.0 / max(k[2], 1e-4) ** 2 for k in group])
                best = float(np.sum(weights * np.array([k[1] for k in group])) / weights.sum())
    corrections = {}
    for key, value, sigma in known:
        off = value - best
        if _reported(off, sigma):
            corrections[key] = float(off)
    return best, corrections


def _reported(off: float, sigma: float) -> bool:
    """Off the kept clock by more than the bound and 5 sigma, and (below 1 s) measured to
    :data:`REPORT_SIGMA_S`: in a formation whose distances barely change (``large``,
    paper-experiment) the estimates of a true 0 reached 0.1-0.5 s at 1-sigma 40-150 ms."""
    if abs(off) <= BOUND_S or abs(off) <= 5.0 * sigma:
        return False
    return abs(off) >= 1.0 or sigma <= REPORT_SIGMA_S


def prepared(session: Session) -> Session:
    """The session with its ``clock`` report: estimated, and with ``[time] offsets =
    "estimate"`` applied (:func:`apply_estimates`); as it is when it has one."""
    if session.clock is not None:
        return session
    if session.config.time_offsets == "estimate":
        return apply_estimates(session)
    return dataclasses.replace(session, clock=estimate_clock(session))


def apply_estimates(session: Session) -> Session:
    """``[time] offsets = "estimate"``: the session with the estimated corrections applied,
    its ``clock`` the report of the estimate on the corrected session (offsets near 0)
    with ``applied`` the corrections, and one note per correction."""
    first = estimate_clock(session)
    if not first.corrections:
        return dataclasses.replace(session, clock=first)
    fixed = apply_corrections(session, first.corrections)
    c = first.corrections
    moved = []  # the offsets against the corrected files: o - c_file + c_ranges
    for o in first.offsets:
        shift = c.get("ranges", 0.0) - c.get(o.key, 0.0)
        nav_shift = c.get(f"nav.{o.platform}", 0.0) - c.get(o.key, 0.0)
        moved.append(
            dataclasses.replace(
                o,
                offset_s=None if o.offset_s is None else o.offset_s + shift,
                against_nav_s=None if o.against_nav_s is None else o.against_nav_s + nav_shift,
            )
        )
    kept, corrections = _corrections(moved)
    report = ClockReport(tuple(moved), kept, corrections, applied=dict(c))
    notes = [
        f'[time] offsets = "estimate": {off:+.3f} s subtracted from the times of '
        f"{_file_of(session, key)} (its estimated clock offset)"
        for key, off in first.corrections.items()
    ]
    return dataclasses.replace(fixed, clock=report, notes=(*session.notes, *notes))


def _file_of(session: Session, key: str) -> str:
    if key == "ranges":
        return name_of(session.ranges.source) or "the ranges"
    kind, pid = key.split(".", 1)
    group = session.nav if kind == "nav" else session.reference
    return name_of(group[pid].source) if pid in group else key


def apply_corrections(session: Session, corrections: Mapping[str, float]) -> Session:
    """The session with ``corrections`` (s, by key) subtracted from the files' times."""
    nav = dict(session.nav)
    reference = dict(session.reference)
    ranges = session.ranges
    for key, off in corrections.items():
        if key == "ranges":
            frame = ranges.frame.copy()
            frame["time"] = frame["time"].to_numpy(dtype=np.float64) - off
            ranges = RangeTable.with_id_codes(frame, ranges.source, ranges.id_codes)
            continue
        kind, pid = key.split(".", 1)
        group = nav if kind == "nav" else reference
        if pid in group:
            group[pid] = dataclasses.replace(group[pid], time_s=group[pid].time_s - off)
    return dataclasses.replace(session, nav=nav, reference=reference, ranges=ranges)
