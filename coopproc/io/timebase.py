"""The session time base: inferred or checked, with messages that name the likely cause.

Decisions (documented in docs/formats.md, "Time base"):

- not given: ``unix`` if any nav/range time exceeds 3.15e8 s (1980 in Unix seconds), else
  ``gps_tow``; a file whose times look like milliseconds counts with its times / 1000;
- a file whose times do not fit the base is one error saying what its times look like
  (Unix seconds, GPS seconds of week, milliseconds) and what to change;
- navigation and ranges whose epochs are all 10 or more apart (median) are milliseconds
  (navigation runs at 1..100 Hz): an error, even when the values fit the base;
- a ``.pos`` file in another GPS week than the session's whose times then fall outside
  the session is one error naming both weeks and the file to fix.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from coopproc import timeconv
from coopproc.errors import ConfigError, CoopprocError, InputError
from coopproc.model import FloatArray, Trajectory

__all__ = [
    "MS_STEP",
    "UNIX_MIN_S",
    "TimedFile",
    "WeekSource",
    "check_times",
    "infer_time_base",
    "looks_like",
    "span_problem",
]

#: Unix seconds at 1980-01-06; any time above this is taken for Unix seconds.
UNIX_MIN_S = timeconv.UNIX_AT_GPS_EPOCH_S
_UNIX_MAX_S = 4.1e9  # year 2099
_TOW_MAX_S = 2 * timeconv.SECONDS_PER_WEEK  # a session may run into the next week
_RELATIVE_MAX_S = 1.0e7
#: Median epoch spacing from which times look like milliseconds (navigation is 1..100 Hz,
#: so its epochs are 0.01..1 s apart; in milliseconds 10..1000).
MS_STEP = 10.0

_EXPECTED = {
    "gps_tow": "GPS seconds of week (0..604800)",
    "unix": "Unix seconds",
    "relative": "seconds from the start",
}
Kind = Literal["unix_ms", "ms", "unix", "tow", "relative", "other"]
_BASE_OF_KIND = {"unix": "unix", "tow": "gps_tow", "relative": "relative"}


@dataclass(frozen=True, eq=False)
class TimedFile:
    """One file's times, already in the session time base."""

    source: str
    time_s: FloatArray
    role: Literal["nav", "ref", "ranges"]
    #: The GPS week of the first epoch of a file with absolute GPST times (.pos), else None.
    gps_week: int | None = None


@dataclass(frozen=True)
class WeekSource:
    """The session's GPS week and where it came from."""

    week: int | None
    #: session.toml path when ``[time] gps_week`` is given there.
    toml: str | None = None
    #: The .pos file whose first epoch gave the week when it is not given.
    taken_from: str | None = None


def _fits(t: FloatArray, base: str) -> bool:
    lo, hi = float(np.min(t)), float(np.max(t))
    if base == "gps_tow":
        return lo >= 0 and hi < _TOW_MAX_S
    if base == "unix":
        return lo > UNIX_MIN_S and hi < _UNIX_MAX_S
    return lo > -_RELATIVE_MAX_S and hi < _RELATIVE_MAX_S


def _median_step(t: FloatArray) -> float | None:
    """Median interval between distinct epochs; None for fewer than four epochs."""
    t = t[np.isfinite(t)]
    step = np.diff(t)
    if np.all(step >= 0):  # in order (as read): np.unique without its sort
        u = t[np.concatenate([[True], step > 0])] if t.size else t
    else:
        u = np.unique(t)
    return float(np.median(np.diff(u))) if u.size >= 4 else None


def looks_like(t: FloatArray) -> tuple[Kind, str]:
    """What times look like, by magnitude and spacing: (kind, words for a message)."""
    lo, hi = float(np.min(t)), float(np.max(t))
    step = _median_step(t)
    if lo > UNIX_MIN_S * 1e3 and hi < _UNIX_MAX_S * 1e3:
        return "unix_ms", "Unix milliseconds"
    if step is not None and step >= MS_STEP and lo >= 0 and hi < _UNIX_MAX_S * 1e3:
        return "ms", f"milliseconds (epochs {step:g} apart, median)"
    if lo > UNIX_MIN_S and hi < _UNIX_MAX_S:
        return "unix", "Unix seconds"
    if lo >= 0 and hi < _TOW_MAX_S:
        return "tow", "GPS seconds of week or seconds from the start"
    if lo > -_RELATIVE_MAX_S and hi < _RELATIVE_MAX_S:
        return "relative", "seconds from the start"
    return "other", "no known time base"


def infer_time_base(files: Sequence[TimedFile]) -> tuple[str, str | None]:
    """(base, the file that decided it): ``unix`` if any time looks like Unix seconds.

    Times that look like milliseconds count divided by 1000, so that the base is the one
    the files are in once converted to seconds.
    """
    top, source = 0.0, None
    for f in files:
        if not f.time_s.size:
            continue
        scale = 1e-3 if looks_like(f.time_s)[0] in ("unix_ms", "ms") else 1.0
        value = float(np.max(f.time_s)) * scale
        if value > top:
            top, source = value, f.source
    return ("unix", source) if top > UNIX_MIN_S else ("gps_tow", None)


@dataclass(frozen=True)
class _Span:
    """The period of the files whose times are in the session base (nav CSV, ranges)."""

    lo: float
    hi: float
    #: What it is the span of, for messages: "the navigation and ranges'", ...
    of: str


def _span(files: Sequence[TimedFile]) -> _Span | None:
    if not files:
        return None
    roles = {f.role for f in files}
    of = {
        frozenset({"ranges"}): "the ranges'",
        frozenset({"nav"}): "the navigation's",
    }.get(frozenset(roles - {"ref"}), "the navigation and ranges'")
    lo = min(float(f.time_s.min()) for f in files)
    return _Span(lo, max(float(f.time_s.max()) for f in files), of)


def _overlaps(t: FloatArray, span: _Span | None) -> bool:
    return span is None or not (float(t.max()) < span.lo or float(t.min()) > span.hi)


def _names(files: Sequence[TimedFile]) -> str:
    return ", ".join(Path(f.source).name for f in files)


def check_times(
    files: Sequence[TimedFile],
    base: str,
    *,
    base_given: bool,
    inferred_from: str | None = None,
    week: WeekSource | None = None,
) -> tuple[list[CoopprocError], set[str]]:
    """Every time-base problem of a session's files, and the sources that have one.

    ``files`` are in the session time base; the caller skips the span checks (reference
    vs navigation, navigation vs ranges) of the returned sources: their times are wrong.
    """
    problems: list[CoopprocError] = []
    bad: set[str] = set()
    own = [f for f in files if f.gps_week is None and f.time_s.size]
    span = _span([f for f in own if _fits(f.time_s, base)])
    if base == "gps_tow" and week is not None and week.week is not None:
        problems.extend(_week_problems(files, week, span, bad))
    failing = [f for f in files if f.time_s.size and f.source not in bad]
    failing = [f for f in failing if not _fits(f.time_s, base)]
    passing = [f for f in own if f not in failing and f.source not in bad]
    if base_given:
        why = f'as [time] base = "{base}" says'
    elif inferred_from is not None:
        why = f"as inferred from {Path(inferred_from).name} ([time] base not given)"
    else:
        why = "as inferred from the times ([time] base not given)"
    for f in failing:
        problems.append(_base_problem(f, base, why, own, passing, base_given))
        bad.add(f.source)
    problems.extend(_millisecond_spacing(own, bad))
    return problems, bad


def _base_problem(
    f: TimedFile,
    base: str,
    why: str,
    own: Sequence[TimedFile],
    passing: Sequence[TimedFile],
    base_given: bool,
) -> InputError:
    """The times of ``f`` do not fit ``base``: what they look like and what to change."""
    kind, words = looks_like(f.time_s)
    if kind in ("unix_ms", "ms"):
        fix = "divide the times by 1000"
    elif (
        base_given
        and kind in _BASE_OF_KIND
        and not passing
        and all(looks_like(g.time_s)[0] == kind for g in own)
    ):
        fix = f'set [time] base = "{_BASE_OF_KIND[kind]}" in session.toml'
    elif passing:
        unit = _EXPECTED[base].split(" (")[0]
        fix = f"convert them to {unit} like {Path(passing[0].source).name}"
    else:
        fix = "give every file one time base"
    lo, hi = float(f.time_s.min()), float(f.time_s.max())
    return InputError(
        f.source,
        f"times {lo:.3f}..{hi:.3f} look like {words}; expected {_EXPECTED[base]} {why}: {fix}",
    )


def _millisecond_spacing(own: Sequence[TimedFile], bad: set[str]) -> list[CoopprocError]:
    """Navigation and ranges whose epochs are all >= MS_STEP apart: milliseconds."""
    checked = [f for f in own if f.role in ("nav", "ranges") and f.source not in bad]
    steps = {f.source: _median_step(f.time_s) for f in checked}
    if not any(f.role == "nav" for f in checked) or not all(
        s is not None and s >= MS_STEP for s in steps.values()
    ):
        return []
    problems: list[CoopprocError] = []
    for f in checked:
        step = steps[f.source]
        assert step is not None
        rate = " (navigation at 1..100 Hz)" if f.role == "nav" else ""
        problems.append(
            InputError(
                f.source,
                f"epochs {step:g} apart (median) look like milliseconds ({1e3 / step:g} Hz); "
                f"expected seconds{rate}: divide the times by 1000",
            )
        )
        bad.add(f.source)
    return problems


def _week_problems(
    files: Sequence[TimedFile],
    week: WeekSource,
    span: _Span | None,
    bad: set[str],
) -> list[CoopprocError]:
    """A .pos file in another GPS week than the session's whose times then do not fit."""
    assert week.week is not None
    absolute = [f for f in files if f.gps_week is not None and f.time_s.size]

    def fine(t: FloatArray) -> bool:
        return _fits(t, "gps_tow") and _overlaps(t, span)

    off = [f for f in absolute if f.gps_week != week.week and not fine(f.time_s)]
    if not off:
        return []
    bad.update(f.source for f in off)
    first = off[0]
    assert first.gps_week is not None
    shift = (week.week - first.gps_week) * timeconv.SECONDS_PER_WEEK
    own_week_fits = fine(first.time_s + shift)
    lo = min(float(f.time_s.min()) for f in off)
    hi = max(float(f.time_s.max()) for f in off)
    outside = (
        f"outside {span.of} {span.lo:.3f}..{span.hi:.3f}"
        if span is not None
        else "outside 0..1209600"
    )
    weeks = sorted({f.gps_week for f in off if f.gps_week is not None})
    if week.toml is not None and not any(fine(f.time_s) for f in absolute):
        held = (
            f"GPS week {weeks[0]}"
            if len(weeks) == 1
            else "GPS weeks " + ", ".join(str(w) for w in weeks)
        )
        fix = (
            f"set gps_week = {first.gps_week} in session.toml"
            if own_week_fits
            else "no week puts them in the session's period: check gps_week and [time] base"
        )
        verb = "is" if len(off) == 1 else "are"
        return [
            ConfigError(
                f"{week.toml} [time] gps_week: {week.week}, but {_names(off)} {verb} in {held} "
                f"(in week {week.week} {'its' if len(off) == 1 else 'their'} times fall at "
                f"{lo:.3f}..{hi:.3f}, {outside}); {fix}"
            )
        ]
    if week.toml is not None:
        said = f"session.toml [time] gps_week is {week.week}"
        like = next(Path(f.source).name for f in absolute if fine(f.time_s))
        fix = f"expected week {week.week} like {like}: check that {{}} belongs to this session"
    else:
        taken = Path(week.taken_from).name if week.taken_from else "the first .pos file"
        said = f"the session's week is {week.week} (of {taken}; [time] gps_week not given)"
        fix = "check that {} belongs to this session, or give [time] gps_week"
    out: list[CoopprocError] = []
    for f in off:
        t = f.time_s
        before, after = fix.split("{}")
        out.append(
            InputError(
                f.source,
                f"epochs in GPS week {f.gps_week}, but {said}; in week {week.week} its times "
                f"fall at {float(t.min()):.3f}..{float(t.max()):.3f}, {outside}; "
                f"{before}{Path(f.source).name}{after}",
            )
        )
    return out


def span_problem(nav: Trajectory, ref: Trajectory) -> InputError | None:
    """The problem of a reference whose time span does not overlap its navigation's."""
    a, b = nav.span_s
    c, d = ref.span_s
    if d < a or c > b:
        return InputError(
            ref.source,
            f"time span {c:.3f}..{d:.3f} does not overlap the navigation's "
            f"{a:.3f}..{b:.3f} ({nav.source}); expected the same period and time base",
        )
    return None
