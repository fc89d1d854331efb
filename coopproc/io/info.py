"""What a session holds: platforms and roles, time spans, rates, pairs, coverage, gaps.

``session_info`` computes the tables (DataFrames with fixed columns); ``format_info``
renders them as the text ``coopproc info`` prints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from coopproc.model import GAP_FACTOR, Session

__all__ = [
    "GAP_FACTOR",
    "PAIR_INFO_COLUMNS",
    "PLATFORM_INFO_COLUMNS",
    "SessionInfo",
    "format_info",
    "gaps",
    "session_info",
]

# GAP_FACTOR: an interval longer than this many times the median interval is a gap, the
# one rule of Trajectory.interpolate_within, the coverage checks and the figures.

PLATFORM_INFO_COLUMNS = (
    "platform",
    "role",
    "epochs",
    "start",
    "end",
    "rate_hz",
    "gaps",
    "longest_gap_s",
    "ref_epochs",
    "ref_coverage",
)
PAIR_INFO_COLUMNS = (
    "pair",
    "ranges",
    "start",
    "end",
    "rate_hz",
    "gaps",
    "longest_gap_s",
    "sigma_given",
)


def gaps(time_s: np.ndarray) -> tuple[float, int, float]:
    """(rate Hz from the median interval, number of gaps, longest gap s)."""
    if time_s.size < 2:
        return float("nan"), 0, 0.0
    dt = np.diff(time_s)
    med = float(np.median(dt))
    if med <= 0:
        return float("nan"), 0, 0.0
    big = dt > GAP_FACTOR * med
    return 1.0 / med, int(big.sum()), float(dt[big].max()) if big.any() else 0.0


def _coverage(ref_t: np.ndarray, start: float, end: float) -> float:
    """Fraction of [start, end] covered by reference intervals that are not gaps."""
    if end <= start or ref_t.size < 2:
        return 0.0
    dt = np.diff(ref_t)
    ok = dt <= GAP_FACTOR * float(np.median(dt))
    lo = np.clip(ref_t[:-1], start, end)
    hi = np.clip(ref_t[1:], start, end)
    return float(np.sum((hi - lo)[ok]) / (end - start))


@dataclass(frozen=True)
class SessionInfo:
    """The facts ``coopproc info`` prints."""

    name: str
    root: str
    time_base: str
    gps_week: int | None
    origin_llh: tuple[float, float, float]
    platforms: pd.DataFrame  # PLATFORM_INFO_COLUMNS
    pairs: pd.DataFrame  # PAIR_INFO_COLUMNS
    notes: tuple[str, ...]


def session_info(session: Session) -> SessionInfo:
    """Compute the platform and pair tables of a session."""
    rows = []
    for pid in session.platform_ids:
        p = session.platforms[pid]
        nav = session.nav.get(pid)
        ref = session.reference.get(pid)
        if nav is None:  # an anchor, or a tag (its reference epochs counted)
            ref_n = 0 if ref is None else len(ref)
            rows.append((pid, p.role, 0, np.nan, np.nan, np.nan, 0, 0.0, ref_n, np.nan))
            continue
        rate, n_gaps, longest = gaps(nav.time_s)
        start, end = nav.span_s
        ref_n = 0 if ref is None else len(ref)
        cov = np.nan if ref is None else _coverage(ref.time_s, start, end)
        rows.append((pid, p.role, len(nav), start, end, rate, n_gaps, longest, ref_n, cov))
    platforms = pd.DataFrame(rows, columns=list(PLATFORM_INFO_COLUMNS))
    prow = []
    frame = session.ranges.frame
    for pair, sub in frame.groupby("pair", sort=True):
        t = np.unique(sub["time"].to_numpy(dtype=np.float64))
        rate, n_gaps, longest = gaps(t)
        given = int(np.isfinite(sub["sigma"].to_numpy(dtype=np.float64)).sum())
        prow.append((pair, len(sub), t[0], t[-1], rate, n_gaps, longest, given))
    pairs = pd.DataFrame(prow, columns=list(PAIR_INFO_COLUMNS))
    return SessionInfo(
        name=session.name,
        root=str(session.root),
        time_base=session.config.time_base,
        gps_week=session.config.gps_week,
        origin_llh=session.origin_llh,
        platforms=platforms,
        pairs=pairs,
        notes=session.notes,
    )


def _fmt(value: object) -> str:
    if isinstance(value, float | np.floating):
        v = float(value)
        if np.isnan(v):
            return "-"
        return f"{v:.3f}" if abs(v) < 1e6 else f"{v:.1f}"
    return str(value)


def _table(frame: pd.DataFrame) -> list[str]:
    cells = [[str(c) for c in frame.columns]]
    cells += [[_fmt(v) for v in row] for row in frame.itertuples(index=False)]
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]))]
    return ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells]


def format_info(info: SessionInfo) -> str:
    """The text ``coopproc info`` prints."""
    week = f", GPS week {info.gps_week}" if info.gps_week is not None else ""
    lat, lon, h = info.origin_llh
    lines = [
        f"session {info.name}  ({info.root})",
        f"time base {info.time_base}{week}; ENU origin {lat:.9f}, {lon:.9f}, {h:.3f} m",
        "",
        "platforms",
        *("  " + s for s in _table(info.platforms)),
        "",
        f"pairs ({int(info.pairs['ranges'].sum()) if len(info.pairs) else 0} ranges)",
        *("  " + s for s in _table(info.pairs)),
    ]
    if info.notes:
        lines += ["", "notes", *("  " + n for n in info.notes)]
    return "\n".join(lines)
