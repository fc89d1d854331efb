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
    out = np.full((len(own), len(columns)), np.nan)
    if ref is None or len(ref) < 2:
        return out
    ref = ref.sort_values("time", kind="stable")
    t_ref = ref["time"].to_numpy(dtype=np.float64)
    t = own["time"].to_numpy(dtype=np.float64)
    inside = (t >= t_ref[0]) & (t <= t_ref[-1])
    # nothing across the reference's gaps (epochs it dropped, outages): the interval
    # around t must be at most GAP_FACTOR x its median, and at least 1 s is always one
    limit = max(gap_limit_s(t_ref), MIN_GAP_S)
    right = np.clip(np.searchsorted(t_ref, t), 1, t_ref.size - 1)
    exact = t_ref[np.minimum(np.searchsorted(t_ref, t), t_ref.size - 1)] == t
    inside &= exact | (t_ref[right] - t_ref[right - 1] <= limit)
    for i, col in enumerate(columns):
        values = ref[col].to_numpy(dtype=np.float64, na_value=np.nan)
        ok = np.isfinite(values)
        if np.count_nonzero(ok) < 2:
            continue
        values = values[ok]
        if col in _ANGLES:
            values = np.degrees(np.unwrap(np.radians(values)))
        truth = np.interp(t, t_ref[ok], values)
        err = own[col].to_numpy(dtype=np.float64, na_value=np.nan) - truth
        if col in _ANGLES:
            err = np.mod(err + 180.0, 360.0) - 180.0
        err[~inside] = np.nan
        out[:, i] = err
    return out


def axis_metrics(
    positions: pd.DataFrame,
    states: pd.DataFrame | None = None,
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """The per-axis table (module docstring): one row per platform and method, rows in
    the order of Table 3 (platform, then ``nav``, ``methods``, the rest alphabetically)."""
    rows: list[dict[str, object]] = []
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    for platform, group in positions.groupby("platform", sort=True):
        refs = group[group["method"] == "reference"]
        ref = refs if len(refs) else None
        st = None if states is None else states[states["platform"] == platform]
        st_ref = None
        if st is not None:
            r = st[st["method"] == "reference"]
            st_ref = r if len(r) else None
        present = sorted(str(m) for m in group["method"].unique() if m != "reference")
        for method in method_order(present, order):
            own = group[group["method"] == method].sort_values("time", kind="stable")
            e = _errors(own, ref, _AXES)
            h = own["error_h"].to_numpy(dtype=np.float64, na_value=np.nan)
            stats: dict[str, object] = {
                "platform": str(platform),
                "method": method,
                "n": int(np.count_nonzero(np.isfinite(h))),
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
