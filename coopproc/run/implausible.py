"""Position methods whose output is not a plausible track: flagged, never silent (issue 31).

Before issue 31, ``lsq`` on hanyang_los had a mean error of 1,706 m (single fixes 10^6 m
off) and the tables printed it without a word. Here every position method's trajectory of
every platform is checked for

- **jumps**: steps between consecutive epochs longer than ``max_jump + max_speed * dt``,
  the platform's plausibility bounds (:func:`coopproc.io.plausible.bounds_of`: session.toml
  ``max_speed`` / ``max_jump``, else the role's, 70 m/s and 5 m), the rule the readers
  apply to a navigation file;
- **a covariance explosion**: a horizontal 1-sigma above :data:`SIGMA_EXPLODED_M`.

A flagged method gets a ``warning:`` line in the closing summary and its counts and first
offending epochs in run.json (``summary.implausible``); its rows stay in positions.csv
(the epochs are named, so a reader can drop them).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from coopproc.io.plausible import bounds_of
from coopproc.model import Session
from coopproc.stages.base import PositionProduct

__all__ = ["SIGMA_EXPLODED_M", "implausible_line", "implausible_methods"]

#: A horizontal 1-sigma above this (m) is an exploded covariance: the anchors' worst
#: accepted fixes (hanyang_los, HDOP 50 x 0.2 m) are 10 m, a filter without updates
#: grows past 100 m within a minute at the default process noise.
SIGMA_EXPLODED_M = 100.0
#: Epochs named per flagged method in run.json.
_FIRST = 5


def implausible_methods(
    session: Session, products: Mapping[str, PositionProduct]
) -> dict[str, dict[str, Any]]:
    """method -> platform -> {epochs, jumps, sigma_exploded, first_times} for each
    trajectory with a jump or an exploded covariance (module docstring)."""
    out: dict[str, dict[str, Any]] = {}
    for method, product in products.items():
        for pid, traj in product.positions.items():
            if len(traj) < 2:
                continue
            b = bounds_of(session.platforms.get(pid))
            t, p = traj.time_s, traj.enu_m[:, :2]
            step = np.linalg.norm(np.diff(p, axis=0), axis=1)
            jump = ~(step <= b.max_jump_m + b.max_speed_mps * np.diff(t))  # NaN: a jump
            sigma = traj.sigma_enu_m
            exploded = np.zeros(t.shape[0], dtype=bool)
            if sigma is not None:
                exploded = np.hypot(sigma[:, 0], sigma[:, 1]) > SIGMA_EXPLODED_M
            if not jump.any() and not exploded.any():
                continue
            bad = np.flatnonzero(np.r_[False, jump] | exploded)
            out.setdefault(method, {})[pid] = {
                "epochs": int(t.shape[0]),
                "jumps": int(jump.sum()),
                "sigma_exploded": int(exploded.sum()),
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
            parts.append(f"{method} on {pid} ({' and '.join(what)} of {f['epochs']} epochs)")
    return (
        "warning: implausible positions, their table rows are not a track: "
        + "; ".join(parts)
        + " (run.json summary.implausible names the first epochs)"
    )
