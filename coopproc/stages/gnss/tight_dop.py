"""Position DOP of the GPS geometry alone and with the UWB ranges (paper 002 Fig. 4).

At every GPS epoch of a platform, at the ``tight`` solution's position: the satellites
the filter used (above the mask, after ``[gnss]`` satellite masking) give the GPS-only
PDOP (rows ``[-u_enu, 1]``); the UWB ranges of that platform within half a second of the
epoch add one row ``[-u_enu, 0]`` per other end (an anchor, or another platform at its
estimate), which gives the PDOP with UWB. Fewer than four satellites leave the GPS-only
PDOP undefined (NaN), while the ranges can still fix the position.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from coopproc.estimation.range_model import slant_ranges_units
from coopproc.gnss.tight import GnssEpochs, LocalFrame, epoch_model, pdop
from coopproc.model import FloatArray
from coopproc.stages.gnss.tight_filter import RangeRows, TrackOutput

__all__ = ["DOP_COLUMNS", "dop_note", "dop_table"]

DOP_COLUMNS = ("time", "platform", "satellites", "uwb_links", "pdop_gnss", "pdop_uwb")


def _at(out: TrackOutput, t: float) -> FloatArray:
    times = np.asarray(out.time_s)
    state = np.asarray(out.state)
    return np.array([np.interp(t, times, state[:, i]) for i in range(3)])


def dop_table(
    epochs: Mapping[str, GnssEpochs],
    outputs: Mapping[str, TrackOutput],
    frame: LocalFrame,
    ranges: RangeRows,
    fixed: Callable[[str, float], tuple[FloatArray, FloatArray] | None],
    keep: Callable[[float], int | None],
    mask_deg: float,
) -> pd.DataFrame:
    """One row per GPS epoch and platform (columns :data:`DOP_COLUMNS`)."""
    rows: list[tuple[float, str, int, int, float, float]] = []
    for pid in sorted(outputs):
        out, ep = outputs[pid], epochs[pid]
        if not out.time_s:
            continue
        mine = np.flatnonzero((np.asarray(ranges.a) == pid) | (np.asarray(ranges.b) == pid))
        for k in range(len(ep)):
            t = float(ep.time_s[k])
            if t < out.time_s[0]:
                continue
            pos = _at(out, t)
            m = epoch_model(ep, k, frame, pos, np.zeros(3), mask_deg)
            n = keep(t)
            order = np.argsort(-m.el, kind="stable")
            los = m.los_enu[order if n is None else order[: max(n, 0)]]
            near = mine[np.abs(ranges.time_s[mine] - t) <= 0.5]
            units = {}
            for j in near:
                other = ranges.b[j] if ranges.a[j] == pid else ranges.a[j]
                if other in units:
                    continue
                there = (
                    _at(outputs[other], t)
                    if other in outputs and outputs[other].time_s
                    else (fixed(other, t) or (None,))[0]
                )
                if there is None:
                    continue
                dist, unit = slant_ranges_units(there - pos)
                if float(dist) > 1e-3:
                    units[other] = unit
            u = np.array(list(units.values())).reshape(-1, 3)
            rows.append((t, pid, int(los.shape[0]), len(units), pdop(los), pdop(los, u)))
    return pd.DataFrame(rows, columns=list(DOP_COLUMNS))


def dop_note(method: str, table: pd.DataFrame) -> list[str]:
    """One line per platform: the PDOP without and with UWB (median, max; epochs)."""
    lines = []
    for pid, g in table.groupby("platform", sort=True):
        alone = g["pdop_gnss"].to_numpy(np.float64)
        joint = g["pdop_uwb"].to_numpy(np.float64)

        def text(v: np.ndarray) -> str:
            ok = v[np.isfinite(v)]
            if not ok.size:
                return f"undefined in all {v.size} epochs"
            return (
                f"median {np.median(ok):.2f}, max {ok.max():.2f}, undefined in "
                f"{v.size - ok.size} of {v.size} epochs"
            )

        lines.append(
            f"{method}: {pid} PDOP of the GPS geometry {text(alone)}; with the UWB ranges "
            f"{text(joint)} (paper 002 Fig. 4)"
        )
    return lines
