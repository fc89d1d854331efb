"""Table 3 per axis: position errors per ENU axis, velocity and attitude errors, per
platform and method, as papers 002 and 003 report them (paper 003 Table 1: RMS per
north/east/down axis, velocity RMS per axis, roll/pitch/yaw RMS).

Pure functions of the output tables. For each platform and method with rows in
``positions`` (method ``reference`` excluded): the error per axis e = value - reference,
the reference rows (method ``reference``) linearly interpolated at the method's epochs
inside their span and not across their gaps (an interval longer than 2.5 x their median
and 1 s: epochs the reference dropped, outages); ``rms_<axis>`` = sqrt(mean e^2),
``max_<axis>`` = max |e| over the epochs that have one (population statistics, as
Table 3). Velocity and attitude come from ``states`` (states.csv) against its
``reference`` rows where the reference has them (velocity columns, heading):
``rms_vel_<axis>`` (m/s), ``rms_roll``, ``rms_pitch``, ``rms_yaw`` (deg; angle
differences wrapped to [-180, 180)). A statistic without epochs is NaN; ``n`` counts the
position epochs with a horizontal error.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from coopproc.model import FloatArray, gap_limit_s
from coopproc.report.methods import method_order, position_methods_of
from coopproc.report.tracks import codes_of, float_column, groups_of, time_order

__all__ = ["AXIS_METRICS_COLUMNS", "axis_metrics"]

_AXES = ("east", "north", "up")
_STATES = ("vel_east", "vel_north", "vel_up", "roll", "pitch", "yaw")
_ANGLES = ("roll", "pitch", "yaw")
#: Reference intervals up to this long (s) are never gaps (bursty range epochs).
MIN_GAP_S = 1.0

#: Columns of the per-axis table.
AXIS_METRICS_COLUMNS: tuple[str, ...] = (
    "platform",
    "method",
    *(f"rms_{a}" for a in _AXES),
    *(f"max_{a}" for a in _AXES),
    *(f"rms_{s}" for s in _STATES),
    "n",
)


def _rms(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def _max(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return float(np.max(np.abs(x))) if x.size else float("nan")


def _errors(own: pd.DataFrame, ref: pd.DataFrame | None, columns: Sequence[str]) -> FloatArray:
    """(n, k) errors of ``own`` against ``ref`` interpolated at its times (NaN outside
    the reference's span or where the reference has no value); angles wrapped."""
    if ref is None or len(ref) < 2:
        return np.full((len(own), len(columns)), np.nan)
    ref = ref.sort_values("time", kind="stable")
    return _errors_at(
        own["time"].to_numpy(dtype=np.float64),
        [own[c].to_numpy(dtype=np.float64, na_value=np.nan) for c in columns],
        ref["time"].to_numpy(dtype=np.float64),
        [ref[c].to_numpy(dtype=np.float64, na_value=np.nan) for c in columns],
        columns,
    )


def _errors_at(
    t: FloatArray,
    own: Sequence[FloatArray],
    t_ref: FloatArray,
    ref: Sequence[FloatArray],
    columns: Sequence[str],
) -> FloatArray:
    """:func:`_errors` of arrays: the values at times ``t`` against the reference's
    (sorted by time, at least two rows), one array per column."""
    out = np.full((t.size, len(columns)), np.nan)
    inside = (t >= t_ref[0]) & (t <= t_ref[-1])
    # nothing across the reference's gaps (epochs it dropped, outages): the interval
    # around t must be at most GAP_FACTOR x its median, and at least 1 s is always one
    limit = max(gap_limit_s(t_ref), MIN_GAP_S)
    right = np.clip(np.searchsorted(t_ref, t), 1, t_ref.size - 1)
    exact = t_ref[np.minimum(np.searchsorted(t_ref, t), t_ref.size - 1)] == t
    inside &= exact | (t_ref[right] - t_ref[right - 1] <= limit)
    for i, col in enumerate(columns):
        values = ref[i]
        ok = np.isfinite(values)
        if np.count_nonzero(ok) < 2:
            continue
        values = values[ok]
        if col in _ANGLES:
            values = np.degrees(np.unwrap(np.radians(values)))
        truth = np.interp(t, t_ref[ok], values)
        err = own[i] - truth
        if col in _ANGLES:
            err = np.mod(err + 180.0, 360.0) - 180.0
        err[~inside] = np.nan
        out[:, i] = err
    return out


def _sorted(
    columns: dict[str, FloatArray], rows: slice | np.ndarray, names: Sequence[str]
) -> list[FloatArray]:
    """The columns ``names`` at ``rows``, the rows in stable time order (time first)."""
    picked = [columns[name][rows] for name in ("time", *names)]
    order = time_order(picked[0])
    return picked if order is None else [v[order] for v in picked]


def axis_metrics(
    positions: pd.DataFrame,
    states: pd.DataFrame | None = None,
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """The per-axis table (module docstring): one row per platform and method, rows in
    the order of Table 3 (platform, then ``nav``, ``methods``, the rest alphabetically).
    The positions are grouped by integer codes in place (:mod:`coopproc.report.tracks`):
    no per-group copies of a day's table."""
    rows: list[dict[str, object]] = []
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    platform_codes, platforms = codes_of(positions["platform"])
    method_codes, names = codes_of(positions["method"])
    columns = {c: float_column(positions, c) for c in ("time", *_AXES, "error_h")}
    by_platform: dict[int, dict[str, slice | np.ndarray]] = {}
    for p, m, group in groups_of(platform_codes, method_codes):
        by_platform.setdefault(p, {})[names[m]] = group
    for code in sorted(by_platform):
        platform, groups = platforms[code], by_platform[code]
        ref = _sorted(columns, groups["reference"], _AXES) if "reference" in groups else None
        st = None if states is None else states[states["platform"] == platform]
        st_ref = None
        if st is not None:
            r = st[st["method"] == "reference"]
            st_ref = r if len(r) else None
        present = sorted(name for name in groups if name != "reference")
        for method in method_order(present, order):
            t, *own = _sorted(columns, groups[method], (*_AXES, "error_h"))
            if ref is None or ref[0].size < 2:
                e = np.full((t.size, len(_AXES)), np.nan)
            else:
                e = _errors_at(t, own[:3], ref[0], ref[1:], _AXES)
            stats: dict[str, object] = {
                "platform": platform,
                "method": method,
                "n": int(np.count_nonzero(np.isfinite(own[3]))),
            }
            for i, axis in enumerate(_AXES):
                stats[f"rms_{axis}"] = _rms(e[:, i])
                stats[f"max_{axis}"] = _max(e[:, i])
            mine = None if st is None else st[st["method"] == method]
            if mine is not None and len(mine):
                es = _errors(mine.sort_values("time", kind="stable"), st_ref, _STATES)
                for i, col in enumerate(_STATES):
                    stats[f"rms_{col}"] = _rms(es[:, i])
            rows.append(stats)
    out = pd.DataFrame(rows, columns=list(AXIS_METRICS_COLUMNS))
    out["n"] = out["n"].astype(np.int64)
    return out
