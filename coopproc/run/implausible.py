"""Position methods whose output is not a plausible track: flagged, never silent (issue 31).

Before issue 31, ``lsq`` on hanyang_los had a mean error of 1,706 m (single fixes 10^6 m
off) and the tables printed it without a word. Here every position method's trajectory of
every platform is checked for

- **jumps**: steps between consecutive epochs longer than ``max_jump + max_speed * dt``,
  the platform's plausibility bounds (:func:`coopproc.io.plausible.bounds_of`: session.toml
  ``max_speed`` / ``max_jump``, else the role's, 70 m/s and 5 m), the rule the readers
  apply to a navigation file;
- **a covariance explosion**: a horizontal 1-sigma above :data:`SIGMA_EXPLODED_M`;
- **a track its ranges deny**: the median |range - distance to the anchor| over the
  platform's ranges to anchors inside the track's span (the track interpolated at each
  range time) above :data:`RANGE_MISFIT_M`. A drift needs no jump: an INS on ranges
  thinned to one per anchor every 3 s (the handcart scenario made a tag) drifted 600 m at
  3 m/s before its start was searched (coopproc.ins.startup), and its ranges were off by
  hundreds of metres (a good track: decimetres).

A flagged method gets a ``warning:`` line in the closing summary and its counts and first
offending epochs in run.json (``summary.implausible``); its rows stay in positions.csv
(the epochs are named, so a reader can drop them).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from coopproc.estimation.range_model import slant_ranges
from coopproc.io.plausible import bounds_of
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.base import PositionProduct

__all__ = ["SIGMA_EXPLODED_M", "implausible_line", "implausible_methods"]

#: A horizontal 1-sigma above this (m) is an exploded covariance: the anchors' worst
#: accepted fixes (hanyang_los, HDOP 50 x 0.2 m) are 10 m, a filter without updates
#: grows past 100 m within a minute at the default process noise.
SIGMA_EXPLODED_M = 100.0
#: A median range misfit above this (m) is a track the ranges deny: every method of the
#: shared real sessions stays within 0.45 m (plaza2's ``lsq_rts``; hanyang_los 0.02 m,
#: tuc 0.1 m), the handcart INS on thinned ranges was 15-184 m off before the searched
#: start (coopproc.ins.startup; now 0.03 m). (The mirror solution
#: of a 3-anchor round fits its ranges: :mod:`~coopproc.stages.anchors.anchor_lsq` guards.)
RANGE_MISFIT_M = 2.0
#: Epochs named per flagged method in run.json.
_FIRST = 5


def implausible_methods(
    session: Session, products: Mapping[str, PositionProduct]
) -> dict[str, dict[str, Any]]:
    """method -> platform -> {epochs, jumps, sigma_exploded, first_times} for each
    trajectory with a jump or an exploded covariance (module docstring)."""
    out: dict[str, dict[str, Any]] = {}
    to_anchors = _anchor_ranges(session)
    for method, product in products.items():
        for pid, traj in product.positions.items():
            if len(traj) < 2:
                continue
            misfit = _misfit(traj, to_anchors.get(pid))
            b = bounds_of(session.platforms.get(pid))
            t, p = traj.time_s, traj.enu_m[:, :2]
            step = np.linalg.norm(np.diff(p, axis=0), axis=1)
            jump = ~(step <= b.max_jump_m + b.max_speed_mps * np.diff(t))  # NaN: a jump
            sigma = traj.sigma_enu_m
            exploded = np.zeros(t.shape[0], dtype=bool)
            if sigma is not None:
                exploded = np.hypot(sigma[:, 0], sigma[:, 1]) > SIGMA_EXPLODED_M
            if not jump.any() and not exploded.any() and not misfit > RANGE_MISFIT_M:
                continue
            bad = np.flatnonzero(np.r_[False, jump] | exploded)
            out.setdefault(method, {})[pid] = {
                "epochs": int(t.shape[0]),
                "jumps": int(jump.sum()),
                "sigma_exploded": int(exploded.sum()),
                "range_misfit_m": round(misfit, 3) if np.isfinite(misfit) else None,
                "first_times": [float(v) for v in t[bad[:_FIRST]]],
                "max_speed_mps": b.max_speed_mps,
                "max_jump_m": b.max_jump_m,
            }
    return out


def implausible_line(flags: Mapping[str, Mapping[str, Any]]) -> str:
    """The summary's warning naming each flagged method, platform and count."""
    parts = []
    for method, by_platform in flags.items():
        for pid, f in by_platform.items():
            what = []
            if f["jumps"]:
                what.append(
                    f"{f['jumps']} jumps beyond {f['max_speed_mps']:g} m/s + {f['max_jump_m']:g} m"
                )
            if f["sigma_exploded"]:
                what.append(f"{f['sigma_exploded']} epochs with 1-sigma > {SIGMA_EXPLODED_M:g} m")
            if (f["range_misfit_m"] or 0.0) > RANGE_MISFIT_M:
                what.append(f"its ranges to anchors off by {f['range_misfit_m']:.1f} m (median)")
            parts.append(f"{method} on {pid} ({' and '.join(what)} of {f['epochs']} epochs)")
    return (
        "warning: implausible positions, their table rows are not a track: "
        + "; ".join(parts)
        + " (run.json summary.implausible names the first epochs)"
    )


def _anchor_ranges(session: Session) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
    """platform -> (times, anchor ENU (n, 3), ranges) of its ranges to anchors."""
    anchors = {
        p: v.position_enu_m
        for p, v in session.platforms.items()
        if v.role == "anchor" and v.position_enu_m is not None
    }
    frame = session.ranges.frame
    if not anchors or frame.empty:
        return {}
    a_to = frame["to"].isin(list(anchors)).to_numpy()
    a_from = frame["from"].isin(list(anchors)).to_numpy()
    keep = (a_to ^ a_from) & np.isfinite(frame["range"].to_numpy(dtype=np.float64))
    own = np.where(a_to, frame["from"].to_numpy(), frame["to"].to_numpy())[keep]
    other = np.where(a_to, frame["to"].to_numpy(), frame["from"].to_numpy())[keep]
    t = frame["time"].to_numpy(dtype=np.float64)[keep]
    r = frame["range"].to_numpy(dtype=np.float64)[keep]
    out = {}
    for pid in set(own.tolist()):
        mine = own == pid
        xyz = np.array([anchors[str(a)] for a in other[mine]], dtype=np.float64)
        out[str(pid)] = (t[mine], xyz, r[mine])
    return out


def _misfit(traj: Trajectory, rows: tuple[FloatArray, FloatArray, FloatArray] | None) -> float:
    """Median |range - distance| of the track at its ranges' times (NaN: none inside)."""
    if rows is None:
        return float("nan")
    t, xyz, r = rows
    inside = (t >= traj.time_s[0]) & (t <= traj.time_s[-1])
    if not inside.any():
        return float("nan")
    p = np.stack([np.interp(t[inside], traj.time_s, traj.enu_m[:, i]) for i in range(3)], 1)
    return float(np.nanmedian(np.abs(r[inside] - slant_ranges(p - xyz[inside]))))
