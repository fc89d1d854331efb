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
data's span, or where less than 30 % of the ranges overlap, are not searched: a
whole-hour time zone is found only in a session longer than about 1.5 hours.

**Reported** (``coopproc validate``, ``coopproc run``): the files whose times run ahead
of (or behind) the session clock by more than :data:`BOUND_S` and 5 sigma (below 1 s,
only those measured to :data:`REPORT_SIGMA_S`: the estimates of weakly observable
formations are biased by the navigation's errors beyond their 1-sigma). The session
clock kept is the one most files share (the ranges' on a tie); the ranges are the odd
one out when every navigation is off by the same amount. The likely cause is named
(:func:`likely_cause`: 18 s leap seconds, whole hours, a unit slip x1000, a latency).

**Applied** on request: ``[time] offsets = "estimate"`` subtracts the reported
corrections (:func:`apply_corrections`); ``[time.offsets]`` constants are subtracted by
the reader (:mod:`coopproc.io.session`) before the time checks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from coopproc.checks.clock_fit import (
    BLOCKS_S,
    NEAR_LAG_S,
    PEAK_STEP_S,
    SEARCH_STEP_S,
    PairData,
    common_lag,
    platform_lag,
    refine,
)
from coopproc.checks.clock_ref import reference_offset
from coopproc.model import (
    ClockReport,
    FloatArray,
    RangeTable,
    Session,
    TimeOffset,
    Trajectory,
    pair_members,
)

__all__ = [
    "BOUND_S",
    "apply_corrections",
    "apply_estimates",
    "clock_facts",
    "clock_lines",
    "estimate_clock",
    "likely_cause",
]

#: Offsets reported above this, s: at the 0.5-1.5 m/s of the paper's platforms 20 ms
#: moves a distance by 1-3 cm, a fifth of the 0.15 m declared ranging sigma or less;
#: a DW1000 logger's own latency is 1-10 ms.
BOUND_S = 0.02
#: Below 1 s, only offsets measured to this 1-sigma are reported (:func:`_reported`), s.
REPORT_SIGMA_S = 0.025
#: Observability: line-of-sight speed, RMS within the bias blocks, m/s (see above).
MIN_SLOPE_MPS = 0.03
#: Observability: ranges of the platform.
MIN_COUNT = 20
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
        near = np.arange(-NEAR_LAG_S, NEAR_LAG_S + SEARCH_STEP_S / 2, SEARCH_STEP_S)
        around = [common + near] if abs(common) < NEAR_LAG_S else [common + near, near]
        candidates = np.unique(np.concatenate(around))
        for pid in free:  # one sweep: each alone, the others at their estimate so far
            found = platform_lag(pid, pairs, positions, start, candidates)
            if found is not None:  # then finer steps around the best
                fine = found.lag_s + np.arange(-1.5, 1.5 + 1e-9, PEAK_STEP_S)
                found = platform_lag(pid, pairs, positions, start, fine) or found
                start[pid] = found.lag_s
        fits = []
        for block in BLOCKS_S:  # each from the last one's offsets: a few iterations
            fits.append(refine(pairs, positions, start, free, block))
            start = {**start, **fits[-1].offset_s}
        fit = min(fits, key=lambda f: float(np.mean([f.sigma_s[p] for p in free])))
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
        if why:
            offsets.append(TimeOffset(key, pid, source, None, None, fit.count[pid], why))
        else:
            nav_fit[pid] = (fit.offset_s[pid], sigma)
            offsets.append(TimeOffset(key, pid, source, fit.offset_s[pid], sigma, fit.count[pid]))
    for pid in sorted(session.reference):
        offsets.append(_reference(session, pid, nav_fit))
    kept, corrections = _corrections(offsets)
    return ClockReport(tuple(offsets), kept, corrections)


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


def likely_cause(offset_s: float, sigma_s: float = 0.0) -> str:
    """The usual suspect of an offset, in words."""
    a = abs(offset_s)
    tol = max(3.0 * sigma_s, 0.05)
    for value, words in (
        (18.0, "the 18 leap seconds between GPS time and UTC (one clock in each)"),
        (19.0, "the 19 s between TAI and GPS time"),
        (37.0, "the 37 s between TAI and UTC"),
    ):
        if abs(a - value) <= tol:
            return words
    half_hours = round(a / 1800.0)
    if half_hours and abs(a - half_hours * 1800.0) <= tol:
        return f"a time zone ({half_hours / 2:g} h: local time against UTC or GPS time)"
    if half_hours and abs(abs(a - half_hours * 1800.0) - 18.0) <= tol:
        return f"a time zone ({half_hours / 2:g} h) and the 18 leap seconds"
    if abs(a - 0.018) <= max(3.0 * sigma_s, 0.002):
        return "18 ms: the 18 leap seconds applied in milliseconds (x1000)"
    if round(a / 3.6) and abs(a - 3.6 * round(a / 3.6)) <= tol:
        return f"{round(a / 3.6)} h / 1000: an hour's correction in the wrong unit (ms vs s)"
    if a >= 1.0 and abs(a - round(a)) <= tol:
        return "a whole number of seconds: a clock stepped, or times rounded to the second"
    if a < 1.0:
        return (
            "a latency (a logging, processing or radio delay, or times stamped at the end "
            "of an epoch instead of its start)"
        )
    return "none of the usual (18 s leap seconds, whole hours, ms vs s)"


def _name(source: str) -> str:
    return Path(source).name if source else source


#: The reason a note names (no motion); the others (too uncertain, e.g. a navigation in
#: a frame of its own; too few ranges or too short an overlap: a tiny session) only go
#: to run.json.
_UNSEEN = ("its navigation moves",)


def clock_lines(session: Session, report: ClockReport) -> tuple[list[str], list[str]]:
    """(warnings, notes) of a clock report: one warning per file off the kept clock, one
    note per platform whose offset is not observable, and what was applied."""
    ranges = _name(session.ranges.source) or "the ranges"
    warnings: list[str] = []
    notes = [
        f"{o.platform}: clock offset of {_name(o.source)} not observable ({o.why})"
        for o in report.offsets
        if o.offset_s is None and o.against_nav_s is None and o.why.startswith(_UNSEEN)
    ]
    for o in report.offsets:
        if o.offset_s is None and o.against_nav_s is not None and abs(o.against_nav_s) > BOUND_S:
            notes.append(
                f"{o.platform}: {_name(o.source)} runs {_ahead(o.against_nav_s)} its "
                f"navigation (its navigation's offset not observable)"
            )
    by_key = {o.key: o for o in report.offsets}
    kept = ranges if "ranges" not in report.corrections else "the navigation"
    hint = '[time] offsets = "estimate" in session.toml applies it, or [time.offsets] '
    for key, off in report.corrections.items():
        if key == "ranges":
            listed = ", ".join(
                f"{o.platform} {o.offset_s:+.3f} +- {o.sigma_s:.3f} s"
                for o in report.offsets
                if o.key.startswith("nav.") and o.offset_s is not None and o.sigma_s is not None
            )
            warnings.append(
                f"clock offset: {ranges} runs {_ahead(off)} the navigation ({listed}); "
                f"likely {likely_cause(off)}: {hint}ranges = {_round(_exact(off))}"
            )
            continue
        o = by_key[key]
        assert o.sigma_s is not None
        used = "ranges" if key.startswith("nav.") else "reference epochs"
        warnings.append(
            f"clock offset: {o.platform}: {_name(o.source)} runs {_ahead(off)} {kept} "
            f"(+- {o.sigma_s:.3f} s, from {o.count} {used}); likely {likely_cause(off, o.sigma_s)}"
            f": {hint}{key} = {_round(_exact(off, o.sigma_s))}"
        )
    for key, value in report.applied.items():
        notes.append(
            f'clock offset applied ([time] offsets = "estimate"): {value:+.3f} s subtracted '
            f"from the times of {key}"
        )
    return warnings, notes


def _exact(off: float, sigma_s: float = 0.0) -> float:
    """The named cause's exact value (18 s, whole hours) when the estimate is within its
    tolerance of it, else the estimate."""
    tol = max(3.0 * sigma_s, 0.05)
    for value in (18.0, 19.0, 37.0):
        if abs(abs(off) - value) <= tol:
            return float(np.copysign(value, off))
    half_hours = round(abs(off) / 1800.0)
    for value in (half_hours * 1800.0, half_hours * 1800.0 + 18.0, half_hours * 1800.0 - 18.0):
        if half_hours and abs(abs(off) - value) <= tol:
            return float(np.copysign(value, off))
    return off


def _ahead(off: float) -> str:
    return f"{abs(off):.3f} s {'ahead of' if off > 0 else 'behind'}"


def _round(off: float) -> str:
    return f"{off:.3f}".rstrip("0").rstrip(".")


def clock_facts(report: ClockReport) -> dict[str, object]:
    """run.json ``clock``: every estimate, the kept clock, the corrections, the applied."""
    return {
        "bound_s": BOUND_S,
        "kept_clock_s": round(report.kept_s, 6),
        "offsets": [
            {
                "file": _name(o.source),
                "key": o.key,
                "offset_s": None if o.offset_s is None else round(o.offset_s, 6),
                "sigma_s": None if o.sigma_s is None else round(o.sigma_s, 6),
                "count": o.count,
            }
            | ({"against_nav_s": round(o.against_nav_s, 6)} if o.against_nav_s is not None else {})
            | ({"not_observable": o.why} if o.offset_s is None and o.why else {})
            for o in report.offsets
        ],
        "corrections_s": {k: round(v, 6) for k, v in report.corrections.items()},
        "applied_s": {k: round(v, 6) for k, v in report.applied.items()},
    }


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
        return _name(session.ranges.source) or "the ranges"
    kind, pid = key.split(".", 1)
    group = session.nav if kind == "nav" else session.reference
    return _name(group[pid].source) if pid in group else key


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
