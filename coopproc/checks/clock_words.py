"""What ``validate`` and ``run`` say about clock offsets, and what run.json records
(:mod:`coopproc.checks.clock`): one warning per file off the session clock with its likely
cause and the fix, notes for what cannot be seen, the ``clock`` facts."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coopproc.clocks import ClockReport
from coopproc.model import Session

__all__ = ["BOUND_S", "clock_facts", "clock_lines", "likely_cause", "name_of"]

#: Offsets reported above this, s: at the 0.5-1.5 m/s of the paper's platforms 20 ms
#: moves a distance by 1-3 cm, a fifth of the 0.15 m declared ranging sigma or less;
#: a DW1000 logger's own latency is 1-10 ms.
BOUND_S = 0.02


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


def name_of(source: str) -> str:
    return Path(source).name if source else source


#: The reason a note names (no motion); the others (too uncertain, e.g. a navigation in
#: a frame of its own; too few ranges or too short an overlap: a tiny session) only go
#: to run.json.
_UNSEEN = ("its navigation moves",)


def clock_lines(session: Session, report: ClockReport) -> tuple[list[str], list[str]]:
    """(warnings, notes) of a clock report: one warning per file off the kept clock, one
    note per platform whose offset is not observable, and what was applied."""
    ranges = name_of(session.ranges.source) or "the ranges"
    warnings: list[str] = []
    notes = [
        f"{o.platform}: clock offset of {name_of(o.source)} not observable ({o.why})"
        for o in report.offsets
        if o.offset_s is None and o.against_nav_s is None and o.why.startswith(_UNSEEN)
    ]
    for o in report.offsets:
        if o.offset_s is None and o.against_nav_s is not None and abs(o.against_nav_s) > BOUND_S:
            notes.append(
                f"{o.platform}: {name_of(o.source)} runs {_ahead(o.against_nav_s)} its "
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
            f"clock offset: {o.platform}: {name_of(o.source)} runs {_ahead(off)} {kept} "
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
                "file": name_of(o.source),
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
