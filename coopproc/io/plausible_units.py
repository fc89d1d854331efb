"""The unit check of :mod:`coopproc.io.plausible`: positions in mm, cm or km, told by
the ranges.

The ranges are checked for metres already (:mod:`coopproc.io.ranges_csv`), so they are
the yardstick: the median range residual |range - |s p - q|| of a platform's ranges to
partners whose positions are known (anchors, the other platforms' navigation) is
computed for each scale s of :data:`UNIT_SCALES`; a scale other than 1 that fits
:data:`UNIT_GAIN` times better than metres, to within :data:`UNIT_FIT` of the median
range, names the unit (x 1000 on sample_logs' nav_A.csv: 0.26 m read as mm, 55,907 m read
as metres). All the ENU navigation files scaled together are tried first (a session
written in mm throughout), then each alone. Lat/lon and ECEF files are not scaled.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import CoopprocError
from coopproc.io._common import RawTrajectory
from coopproc.model import FloatArray, Platform, RangeTable, Trajectory

__all__ = ["UNIT_FIT", "UNIT_GAIN", "UNIT_SCALES", "position_units"]

#: Scales tried on positions, with the unit they stand for and the fix.
UNIT_SCALES: tuple[tuple[float, str, str, str], ...] = (
    (1e-3, "millimetres", "divide the positions by 1000", "mm"),
    (1e-2, "centimetres", "divide the positions by 100", "cm"),
    (1e3, "kilometres", "multiply the positions by 1000", "km"),
)
#: A scale must fit this many times better than metres...
UNIT_GAIN = 5.0
#: ...and to within this share of the median range.
UNIT_FIT = 0.25
#: Ranges used per platform for the unit check at most (evenly subsampled), and at least.
_UNIT_RANGES = 2000
_UNIT_MIN = 20


def _m(value: float) -> str:
    """A length for messages: 0.259, 12.3, 55,910."""
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.3g}"


def _partner_rows(
    ranges: RangeTable,
    pid: str,
    nav: Mapping[str, Trajectory],
    anchors: Mapping[str, FloatArray],
) -> tuple[FloatArray, FloatArray, NDArray[np.object_]] | None:
    """(times, ranges, partner of each) of ``pid``'s ranges to known partners (subsampled)."""
    ids, first, second = ranges.id_codes
    at = int(np.searchsorted(ids, pid))
    if at >= ids.shape[0] or ids[at] != pid:
        return None
    known_id = np.array([i in anchors or (i in nav and i != pid) for i in ids], dtype=bool)
    mine = (first == at) | (second == at)
    other = np.where(first == at, second, first)
    rows = np.flatnonzero(mine & known_id[other])
    if rows.size < _UNIT_MIN:
        return None
    if rows.size > _UNIT_RANGES:
        rows = rows[np.linspace(0, rows.size - 1, _UNIT_RANGES).round().astype(np.intp)]
    frame = ranges.frame
    t = frame["time"].to_numpy(dtype=np.float64)[rows]
    r = frame["range"].to_numpy(dtype=np.float64)[rows]
    return t, r, np.asarray(ids, dtype=object)[other[rows]]


def _misfit(
    pid: str,
    data: tuple[FloatArray, FloatArray, NDArray[np.object_]],
    nav: Mapping[str, Trajectory],
    anchors: Mapping[str, FloatArray],
    scale: Mapping[str, float],
) -> float:
    """Median |range - |s_P p - s_Q q||, the positions scaled by ``scale`` (default 1)."""
    t, r, names = data
    own = nav[pid].interpolate(t) * scale.get(pid, 1.0)
    other = np.empty_like(own)
    for name in set(names.tolist()):
        sel = names == name
        if name in anchors:
            other[sel] = anchors[name]
        else:
            other[sel] = nav[name].interpolate(t[sel]) * scale.get(name, 1.0)
    with np.errstate(invalid="ignore", over="ignore"):
        res = np.abs(r - np.linalg.norm(own - other, axis=1))
    res = res[np.isfinite(res)]
    return float(np.median(res)) if res.size >= _UNIT_MIN else float("nan")


def position_units(
    raws: Mapping[str, RawTrajectory],
    nav: Mapping[str, Trajectory],
    platforms: Mapping[str, Platform],
    ranges: RangeTable | None,
    problems: list[CoopprocError],
) -> set[str]:
    """The platforms whose navigation positions look like another unit (see the module),
    one problem each appended to ``problems``."""
    if ranges is None or not len(ranges):
        return set()
    anchors = {
        pid: np.asarray(p.position_enu_m, dtype=np.float64)
        for pid, p in platforms.items()
        if p.role == "anchor" and p.position_enu_m is not None and pid not in nav
    }
    enu = sorted(pid for pid in nav if raws[pid].form == "enu")
    data = {pid: _partner_rows(ranges, pid, nav, anchors) for pid in enu}
    usable = {pid: d for pid, d in data.items() if d is not None}
    if not usable:
        return set()
    median_range = float(np.median(ranges.frame["range"].to_numpy(dtype=np.float64)))

    def best(scales: list[dict[str, float]], pids: list[str]) -> tuple[int, float, float] | None:
        fits = [
            np.nanmedian([_misfit(pid, usable[pid], nav, anchors, s) for pid in pids])
            if pids
            else np.nan
            for s in scales
        ]
        base = fits[0]
        if not np.isfinite(base):
            return None
        k = int(np.nanargmin(fits)) if np.isfinite(fits).any() else 0
        if k and fits[k] * UNIT_GAIN < base and fits[k] <= UNIT_FIT * median_range:
            return k, float(fits[k]), float(base)
        return None

    def report(pids: list[str], found: tuple[int, float, float]) -> None:
        k, fit, base = found
        _scale, unit, fix, key = UNIT_SCALES[k - 1]
        # [columns.nav.units] converts every nav file: offered when all are in the unit
        declare = f' or declare session.toml [columns.nav.units] position = "{key}"'
        for pid in pids:
            problems.append(
                raws[pid].error(
                    f"positions look like {unit}: the ranges fit them to {_m(fit)} m "
                    f"(median residual) read so, to {_m(base)} m read as metres; expected "
                    f"metres: {fix}{',' + declare if len(pids) > 1 else ''}",
                    0,
                )
            )

    scales = [1.0, *(unit[0] for unit in UNIT_SCALES)]
    together = [{pid: s for pid in enu} for s in scales]
    found = best(together, sorted(usable)) if len(enu) > 1 else None
    if found is not None:
        report(enu, found)
        return set(enu)
    flagged: set[str] = set()
    for pid in sorted(usable):
        alone = [{pid: s} for s in scales]
        found = best(alone, [pid])
        if found is not None:
            report([pid], found)
            flagged.add(pid)
    return flagged
