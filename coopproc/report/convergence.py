"""The panels of the NLOS convergence figure: one per event of the primary method.

The estimates of each event (``nlos_estimates``: one ``event`` number per pair, method
and event) take the ``[start, end]`` span of the ``nlos_events`` row of their pair and
method that holds their step times. The estimation steps cover only the first seconds of
an event, so events are put together by these spans, never by the times of each other's
steps. Every event with estimates is drawn:

- each event of the primary method gets a panel;
- an event of another method joins the primary panel of its pair whose span overlaps its
  own the most (one event per method and panel, as a panel draws one series per method);
- an event that overlaps none, or whose panel already holds an event of its method, gets
  a panel of its own.

A panel is titled with the pair and number of its first event and the event's start
since t0, e.g. ``A-B, event 2 (t = 381 s)``, and the event's method when it is not the
primary one (``B-C, RN-Based event 3 (t = 485 s)``).

Estimates whose steps lie in no event's span (tables written without their events) keep
the span of their own step times. Grouped once: the estimates and events per (pair,
method), the ranges per pair; each panel's reference bias comes from its own pair's
ranges over the span of its first event.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from coopproc.report.methods import nlos_methods, primary_method
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import groups
from coopproc.report.run_tables import RunTables
from coopproc.report.scores import event_bias
from coopproc.report.tables import method_label

__all__ = ["EventEstimates", "convergence_panels", "event_estimates"]

#: Slack (s) when comparing step times with event bounds (both written to the microsecond).
_TIME_TOL_S = 1e-6


@dataclass(frozen=True)
class EventEstimates:
    """One event's estimates with the span of its ``nlos_events`` row."""

    pair: str
    method: str
    #: The ``event`` number of its estimates (from 1 per pair and method).
    number: int
    start: float
    end: float
    rows: pd.DataFrame


def _primary_estimates(run: RunTables) -> str | None:
    est = run.nlos_estimates
    if est is None or not len(est):
        return None
    have = {str(m) for m in est["method"].unique()}
    preferred = [m for m in (primary_method(run), *nlos_methods(run)) if m in have]
    return preferred[0] if preferred else sorted(have)[0]


def _match(pair: str, method: str, rows: pd.DataFrame, spans: pd.DataFrame) -> list[EventEstimates]:
    """Each event's estimates of one pair and method (``rows``, one ``event`` number per
    event) with the span of the ``spans`` row (nlos_events) holding most of its step
    times; estimates whose steps lie in no span keep the span of their own steps."""
    order = np.argsort(spans["start"].to_numpy(dtype=np.float64), kind="stable")
    starts = spans["start"].to_numpy(dtype=np.float64)[order]
    ends = spans["end"].to_numpy(dtype=np.float64)[order]
    out = []
    for _, part in rows.groupby("event", sort=True):
        t = part["time"].to_numpy(dtype=np.float64)
        # the last span starting at or before each step (a method's events do not overlap)
        at = np.searchsorted(starts, t + _TIME_TOL_S, side="right") - 1
        hit = at[(at >= 0) & (t <= ends[np.maximum(at, 0)] + _TIME_TOL_S)] if len(ends) else at[:0]
        if hit.size:
            best = int(np.bincount(hit).argmax())
            lo, hi = float(starts[best]), float(ends[best])
        else:
            lo, hi = float(t.min()), float(t.max())
        part = part.sort_values("step", kind="stable")
        number = int(part["event"].iloc[0])
        out.append(EventEstimates(pair, method, number, lo, hi, part))
    return sorted(out, key=lambda e: (e.start, e.number))


def event_estimates(run: RunTables, options: FigureOptions | None = None) -> list[EventEstimates]:
    """Every event with estimates, by pair, method and start (see the module docstring);
    ``options``: only the chosen pairs."""
    opts = options or FigureOptions()
    est = run.nlos_estimates
    if est is None or not len(est):
        return []
    events = run.nlos_events
    spans = {(str(p), str(m)): g for (p, m), g in events.groupby(["pair", "method"], sort=False)}
    out = []
    for (pair, method), rows in est.groupby(["pair", "method"], sort=True):
        if opts.keep_pair(str(pair)):
            own = spans.get((str(pair), str(method)), events.iloc[:0])
            out.extend(_match(str(pair), str(method), rows, own))
    return out


def _overlap(a: EventEstimates, b: EventEstimates) -> float | None:
    """Length of the overlap of two closed spans, None if they do not meet."""
    lo, hi = max(a.start, b.start), min(a.end, b.end)
    return hi - lo if hi >= lo - _TIME_TOL_S else None


def convergence_panels(
    run: RunTables, options: FigureOptions | None = None
) -> list[tuple[str, pd.DataFrame, float | None]]:
    """(title, estimate rows of every method, reference bias) per panel, pair by pair in
    time order (see the module docstring).

    The primary method is the run's (:func:`~coopproc.report.methods.primary_method`) if
    it has estimates, else the first NLOS method with estimates, else the first by name.
    ``options``: only the chosen pairs.
    """
    primary = _primary_estimates(run)
    if primary is None:
        return []
    by_pair: dict[str, list[EventEstimates]] = {}
    for ev in event_estimates(run, options):
        by_pair.setdefault(ev.pair, []).append(ev)
    ranges = groups(run.ranges, "pair") if by_pair else {}
    panels = []
    t0 = run.time_origin_s  # once: a min over the ranges and positions tables
    for pair in sorted(by_pair):
        mains = [e for e in by_pair[pair] if e.method == primary]  # in time order
        main_starts = np.array([e.start for e in mains], dtype=np.float64)
        main_ends = np.maximum.accumulate(np.array([e.end for e in mains], dtype=np.float64))
        members: list[list[EventEstimates]] = [[e] for e in mains]
        alone: list[EventEstimates] = []
        for ev in by_pair[pair]:
            if ev.method == primary:
                continue
            # the primary events meeting this one (they do not overlap each other)
            first = int(np.searchsorted(main_ends, ev.start - _TIME_TOL_S, side="left"))
            last = int(np.searchsorted(main_starts, ev.end + _TIME_TOL_S, side="right"))
            best, best_len = None, -1.0
            for i in range(first, last):
                length = _overlap(mains[i], ev)
                taken = any(m.method == ev.method for m in members[i])
                if length is not None and not taken and length > best_len:
                    best, best_len = i, length
            if best is None:
                alone.append(ev)
            else:
                members[best].append(ev)
        groups_in_time = sorted([*members, *([e] for e in alone)], key=lambda g: g[0].start)
        for group in groups_in_time:
            head = group[0]
            # the primary method's panels unnamed: the titles fit a third of the text width
            name = "" if head.method == primary else f"{method_label(head.method)} "
            at = head.start - t0
            title = f"{pair}, {name}event {head.number} (t = {at:.0f} s)"
            bias = _reference_bias(ranges.get(pair), head)
            panels.append((title, pd.concat([e.rows for e in group]), bias))
    return panels


def _reference_bias(pair_ranges: pd.DataFrame | None, event: EventEstimates) -> float | None:
    """The mean of observed - reference over the event's span."""
    if pair_ranges is None or not {"observed", "reference"} <= set(pair_ranges.columns):
        return None
    bias, n = event_bias(pair_ranges, event.start, event.end)
    return bias if n else None
