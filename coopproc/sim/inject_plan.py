"""The events of ``coopproc inject`` and their checks against the session they go into.

An :class:`Injection` lists NLOS errors (paper 000 sec. 4.3), gross errors (paper 002
sec. 5.4) and UWB outages (paper 003 sec. 3.4). Times are in the session's time base, or,
written ``+S``, ``S`` seconds from the session start (its first navigation or range
epoch, as ``coopproc validate`` counts). :func:`resolve_injection` turns every time into
an absolute one, every pair into the session's spelling, and refuses, with one line
naming the option, what cannot be injected: an unknown pair (naming the nearest valid
one), a window outside the span of the session's ranges or holding no range, a
non-positive NLOS mean, a negative sd, a zero gross error, NLOS windows that overlap on
one pair.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from coopproc.configtools import nearest
from coopproc.errors import ConfigError
from coopproc.model import Session, pair_members

__all__ = [
    "GrossInjection",
    "Injection",
    "NlosInjection",
    "OutageInjection",
    "SessionSpan",
    "resolve_injection",
    "session_span",
]

Time = float | str


def _text(value: Time) -> str:
    """A time as written: ``+S`` as given, a number without trailing zeros."""
    return value if isinstance(value, str) else f"{value:.6f}".rstrip("0").rstrip(".")


@dataclass(frozen=True)
class NlosInjection:
    """N(mean, sd^2) metres added to every range of ``pair`` in [start, end]."""

    pair: str
    start: Time
    end: Time
    mean: float
    sd: float

    def option(self) -> str:
        """The option as a user writes it (for messages)."""
        return f"--nlos {self.pair} {_text(self.start)} {_text(self.end)} {self.mean:g} {self.sd:g}"


@dataclass(frozen=True)
class GrossInjection:
    """``size`` metres added to the range(s) of ``pair`` nearest to ``time``."""

    pair: str
    time: Time
    size: float

    def option(self) -> str:
        return f"--gross {self.pair} {_text(self.time)} {self.size:g}"


@dataclass(frozen=True)
class OutageInjection:
    """Every range in [start, end] removed, of ``pairs`` (empty: every pair)."""

    start: Time
    end: Time
    pairs: tuple[str, ...] = ()

    def option(self) -> str:
        only = f" --pairs {','.join(self.pairs)}" if self.pairs else ""
        return f"--outage {_text(self.start)} {_text(self.end)}{only}"


@dataclass(frozen=True)
class Injection:
    """Everything to inject, and the seed of the NLOS draws (numpy ``default_rng``)."""

    nlos: tuple[NlosInjection, ...] = ()
    gross: tuple[GrossInjection, ...] = ()
    outages: tuple[OutageInjection, ...] = ()
    seed: int = 0


@dataclass(frozen=True)
class SessionSpan:
    """Where a session's times lie: its start (``+S`` counts from it) and its ranges."""

    start_s: float
    first_range_s: float
    last_range_s: float

    def time(self, value: Time, option: str) -> float:
        """An absolute time from a number or ``+S``; ConfigError for anything else."""
        if isinstance(value, str):
            text = value.strip()
            try:
                number = float(text[1:] if text.startswith("+") else text)
            except ValueError:
                raise ConfigError(
                    f"{option}: time {value!r} is not a number; expected seconds in the "
                    "session's time base, or +S for S seconds from the session start"
                ) from None
            value_s = self.start_s + number if text.startswith("+") else number
        else:
            value_s = float(value)
        if not math.isfinite(value_s):
            raise ConfigError(f"{option}: time {value!r} is not finite")
        return value_s

    def describe(self) -> str:
        """The ranges' span, absolute and from the start, for messages."""
        return (
            f"the session's ranges span {self.first_range_s:.3f}..{self.last_range_s:.3f} "
            f"(+{self.first_range_s - self.start_s:.1f}..+{self.last_range_s - self.start_s:.1f}"
            " s from the session start)"
        )

    def check_window(self, start_s: float, end_s: float, option: str) -> None:
        """A window must lie within the ranges' span."""
        if start_s > self.last_range_s or end_s < self.first_range_s:
            raise ConfigError(f"{option}: window outside the session; {self.describe()}")
        if start_s < self.first_range_s or end_s > self.last_range_s:
            raise ConfigError(f"{option}: window reaches outside the session; {self.describe()}")


def session_span(session: Session) -> SessionSpan:
    """The start and the ranges' span of a session (docs/inject.md)."""
    times = session.ranges.frame["time"].to_numpy(dtype=np.float64)
    firsts = [float(traj.time_s[0]) for traj in session.nav.values() if len(traj)]
    return SessionSpan(
        start_s=min([float(times.min()), *firsts]),
        first_range_s=float(times.min()),
        last_range_s=float(times.max()),
    )


def _pair(given: str, pairs: Sequence[str], option: str) -> str:
    """The session's spelling of a pair (``B-A`` is ``A-B``); ConfigError naming the
    nearest valid pair."""
    text = given.strip()
    if text in pairs:
        return text
    for pair in pairs:
        first, second = pair_members(pair)
        if text == f"{second}-{first}":
            return pair
    raise ConfigError(f"{option}: no ranges of pair '{given}' in the session{nearest(text, pairs)}")


def _count(times: np.ndarray, start_s: float, end_s: float) -> int:
    return int(np.count_nonzero((times >= start_s) & (times <= end_s)))


def resolve_injection(injection: Injection, session: Session) -> Injection:
    """``injection`` with absolute times and the session's pair names, checked (module doc)."""
    if not (injection.nlos or injection.gross or injection.outages):
        raise ConfigError("nothing to inject: give --nlos, --gross or --outage")
    span = session_span(session)
    frame = session.ranges.frame
    pairs = session.ranges.pairs
    pair_times = {
        p: g["time"].to_numpy(dtype=np.float64) for p, g in frame.groupby("pair", sort=False)
    }
    outages: list[OutageInjection] = []
    removals: list[tuple[str, OutageInjection]] = []  # (the option as given, resolved)
    for o in injection.outages:
        option = o.option()
        chosen = tuple(dict.fromkeys(_pair(p, pairs, option) for p in o.pairs))
        start, end = span.time(o.start, option), span.time(o.end, option)
        if not end > start:
            raise ConfigError(f"{option}: END must be after START")
        span.check_window(start, end, option)
        if not sum(_count(pair_times[p], start, end) for p in chosen or pairs):
            raise ConfigError(f"{option}: no range in the window")
        outages.append(replace(o, start=start, end=end, pairs=chosen))
        removals.append((option, outages[-1]))

    def removed_by(pair: str, times: np.ndarray) -> list[str | None]:
        """Per time, the first outage (as given) that removes the range there, else None."""
        out: list[str | None] = [None] * len(times)
        for option, o in reversed(removals):
            if not o.pairs or pair in o.pairs:
                for i in np.flatnonzero((times >= float(o.start)) & (times <= float(o.end))):
                    out[i] = option
        return out

    nlos: list[NlosInjection] = []
    for ev in injection.nlos:
        option = ev.option()
        pair = _pair(ev.pair, pairs, option)
        start, end = span.time(ev.start, option), span.time(ev.end, option)
        if not end > start:
            raise ConfigError(f"{option}: END must be after START")
        if not (math.isfinite(ev.mean) and ev.mean > 0):
            raise ConfigError(f"{option}: MEAN {ev.mean:g}; expected metres > 0 (NLOS lengthens)")
        if not (math.isfinite(ev.sd) and ev.sd >= 0):
            raise ConfigError(f"{option}: SD {ev.sd:g}; expected metres >= 0")
        span.check_window(start, end, option)
        times = pair_times[pair]
        inside = times[(times >= start) & (times <= end)]
        if not inside.size:
            raise ConfigError(f"{option}: no range of {pair} in the window")
        gone = removed_by(pair, inside)
        if all(gone):
            raise ConfigError(f"{option}: every range in the window is removed by {gone[0]}")
        for other in nlos:
            if other.pair == pair and start <= float(other.end) and end >= float(other.start):
                raise ConfigError(f"{option}: overlaps an earlier --nlos window on {pair}")
        nlos.append(replace(ev, pair=pair, start=start, end=end))
    gross: list[GrossInjection] = []
    for g in injection.gross:
        option = g.option()
        pair = _pair(g.pair, pairs, option)
        time = span.time(g.time, option)
        if not (math.isfinite(g.size) and g.size != 0):
            raise ConfigError(f"{option}: SIZE {g.size:g}; expected metres, not 0")
        span.check_window(time, time, option)
        gap = np.abs(pair_times[pair] - time)
        nearest_s = pair_times[pair][gap == gap.min()]
        for t, by in zip(nearest_s, removed_by(pair, nearest_s), strict=True):
            if by is not None:
                raise ConfigError(f"{option}: its nearest range (at {t:.3f}) is removed by {by}")
        gross.append(replace(g, pair=pair, time=time))
    return Injection(tuple(nlos), tuple(gross), tuple(outages), injection.seed)
