"""Turn raw trajectories and ranges into one Session: time base, origin, ENU, checks.

Decisions (documented in docs/formats.md):

- the time base, the GPS week and the checks of every file's times against them are in
  :mod:`coopproc.io.timebase`; :func:`to_session_time` converts GPST times to the base;
- reference epochs whose quality is not in ``[reference] quality`` are dropped (noted);
- origin: ``[frame] origin``, else the first geodetic/ECEF reference fix (platforms in
  sorted order), else the first geodetic/ECEF nav fix; all-ENU sessions record (0, 0, 0).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from coopproc import timeconv
from coopproc.errors import CoopprocError, InputError
from coopproc.frames import ecef2enu, ecef2geodetic, ecef_cov2enu_sigma, geodetic2enu
from coopproc.io._common import RawTrajectory
from coopproc.io.ranges_csv import RangesRead
from coopproc.model import Platform, SessionConfig, Trajectory

__all__ = [
    "check_ranges",
    "choose_origin",
    "filter_quality",
    "platforms_of",
    "to_session_time",
    "to_trajectory",
]


def to_session_time(raw: RawTrajectory, base: str, gps_week: int | None) -> RawTrajectory:
    """Convert a GPST-kind raw trajectory to the session time base (a new object)."""
    if raw.time_kind == "session":
        return raw
    if base == "gps_tow":
        assert gps_week is not None
        # absolute GPST seconds (~1.3e9) hold float64 steps of 2.4e-7 s: the time of week
        # keeps the microsecond, not that step (a .pos "06:00:00.200" is 108000.2, not
        # 108000.20000004768), so the same session read from an MCAP file, whose stamps
        # are nanoseconds, has the same times
        t = np.round(raw.time_s - gps_week * timeconv.SECONDS_PER_WEEK, 6)
    elif base == "unix":
        t = timeconv.gpst_to_unix(raw.time_s)
    else:
        raise InputError(
            raw.source,
            'absolute GPS times cannot be aligned with [time] base = "relative"; expected '
            "base gps_tow or unix, or the reference as ref_<ID>.csv in relative seconds",
        )
    # the other arrays shared, not copied (nothing writes into them)
    return dataclasses.replace(raw, time_s=t, time_kind="session", notes=list(raw.notes))


def filter_quality(raw: RawTrajectory, accepted: tuple[int, ...]) -> tuple[RawTrajectory, str]:
    """Keep epochs whose quality is accepted; a note when some were dropped."""
    if raw.quality is None:
        return raw, ""
    keep = np.isin(raw.quality, np.asarray(accepted, dtype=np.int64))
    if keep.all():
        return raw, ""
    dropped = int(keep.size - keep.sum())
    note = (
        f"{raw.source}: {dropped} of {keep.size} epochs with Q not in {list(accepted)} "
        "dropped from the reference"
    )
    return raw.take(np.flatnonzero(keep)), note


def _first_llh(raw: RawTrajectory) -> tuple[float, float, float] | None:
    if raw.time_s.size == 0 or raw.form == "enu":
        return None
    first = raw.position[0]
    if raw.form == "ecef":
        first = ecef2geodetic(first)[0]
    return float(first[0]), float(first[1]), float(first[2])


def choose_origin(
    config: SessionConfig,
    reference: Mapping[str, RawTrajectory],
    nav: Mapping[str, RawTrajectory],
) -> tuple[tuple[float, float, float], str]:
    """The ENU origin (lat deg, lon deg, h m) and a note saying where it came from."""
    if config.origin_llh is not None:
        return tuple(float(v) for v in config.origin_llh), ""  # type: ignore[return-value]
    for what, group in (("reference", reference), ("navigation", nav)):
        for pid in sorted(group):
            llh = _first_llh(group[pid])
            if llh is not None:
                note = (
                    f"ENU origin not given ([frame] origin): first {what} fix of {pid} "
                    f"({llh[0]:.9f}, {llh[1]:.9f}, {llh[2]:.3f}) used"
                )
                return llh, note
    return (0.0, 0.0, 0.0), ""


def to_trajectory(raw: RawTrajectory, origin: tuple[float, float, float]) -> Trajectory:
    """The model trajectory of a raw one, positions in ENU at ``origin``."""
    if raw.form == "llh":
        enu = geodetic2enu(raw.position, origin)
    elif raw.form == "ecef":
        enu = ecef2enu(raw.position, origin)
    else:
        enu = np.ascontiguousarray(raw.position, dtype=np.float64)
    sigma = raw.sigma_enu_m
    if sigma is None and raw.cov_ecef_m2 is not None:
        sigma = ecef_cov2enu_sigma(raw.cov_ecef_m2, origin)
    return Trajectory(
        platform=raw.platform,
        time_s=np.ascontiguousarray(raw.time_s, dtype=np.float64),
        enu_m=enu,
        sigma_enu_m=sigma,
        vel_enu_mps=raw.vel_enu_mps,
        heading_deg=raw.heading_deg,
        quality=raw.quality,
        source=raw.source,
    )


def platforms_of(
    config: SessionConfig, nav_ids: set[str], notes: list[str], problems: list[CoopprocError]
) -> dict[str, Platform]:
    """Platforms with navigation, anchors with a position and tags; defaults noted."""
    out: dict[str, Platform] = {}
    defaulted = []
    for pid in sorted(nav_ids):
        if pid in config.platforms:
            out[pid] = config.platforms[pid]
            if out[pid].role == "tag":
                problems.append(
                    InputError(
                        "session.toml",
                        f'[platforms.{pid}] role = "tag": {pid} has a navigation file, but a '
                        "tag has no navigation of its own; expected role follower or leader",
                    )
                )
        else:
            out[pid] = Platform(pid)
            defaulted.append(pid)
    if defaulted:
        notes.append(f"no role given for {', '.join(defaulted)}: follower assumed")
    for pid, p in sorted(config.platforms.items()):
        if pid in out:
            continue
        if (p.role == "anchor" and p.position_enu_m is not None) or p.role == "tag":
            out[pid] = p  # a tag is positioned from its ranges: no navigation file
        elif p.role == "anchor":
            problems.append(
                InputError(
                    "session.toml",
                    f"[platforms.{pid}]: anchor without navigation file nor position; "
                    "expected position = [east, north, up]",
                )
            )
        else:
            notes.append(f"[platforms.{pid}] has no navigation file; {pid} left out")
    return out


def check_ranges(
    ranges: RangesRead,
    platforms: Mapping[str, Platform],
    nav: Mapping[str, Trajectory],
    skip: set[str],
    spans: Mapping[str, Trajectory] | None = None,
) -> list[CoopprocError]:
    """Ranges naming platforms without navigation, and time spans that do not overlap.

    ``spans``: the navigation whose span is checked against the ranges' (default all of
    ``nav``; the loader leaves out files whose times already failed the time-base check).
    """
    problems: list[CoopprocError] = []
    frame = ranges.table.frame
    ids, first, second = ranges.table.id_codes  # integer codes, no string per row
    known = set(platforms) | skip
    expected = ", ".join(sorted(platforms)) or "none"
    for pid in sorted({str(i) for i in ids} - known):
        at = int(np.searchsorted(ids, pid))
        rows = np.flatnonzero((first == at) | (second == at))
        problems.append(
            ranges.error(
                f"platform '{pid}' has no navigation (nav_{pid}.csv) and is not an anchor; "
                f"expected one of {expected}",
                int(rows[0]),
                rows.size,
            )
        )
    times = frame["time"].to_numpy(dtype=np.float64)
    lo, hi = float(times.min()), float(times.max())
    spans = nav if spans is None else spans
    for pid in sorted(spans):
        a, b = spans[pid].span_s
        if b < lo or a > hi:
            problems.append(
                InputError(
                    spans[pid].source,
                    f"time span {a:.3f}..{b:.3f} does not overlap the ranges' "
                    f"{lo:.3f}..{hi:.3f} ({ranges.where.path}); expected the same period "
                    "and time base",
                )
            )
    return problems
