"""The session's range table at its range epochs: the rows every range method fills.

One row per range epoch and pair: the pairs in session order (``session.ranges.pairs``),
each pair's ranges by time (stable, so ranges at one time keep their file order);
columns ``time, pair, observed, reference``, the reference being the distance between
the two reference trajectories (NaN inside a reference gap or where there is none,
DATA.md). Every range processor's columns are aligned with these rows.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, Session, Trajectory, pair_members

__all__ = [
    "observed_table",
    "pair_columns",
    "pair_rows",
    "platform_positions",
    "reference_positions",
]


def platform_positions(
    session: Session,
    source: Mapping[str, Trajectory],
    platform: str,
    time_s: FloatArray,
    what: str,
    required: bool,
) -> FloatArray:
    """Positions of ``platform`` from ``source`` at ``time_s`` (an anchor: its fixed
    position); a platform missing from ``source`` is an error if ``required``, else NaN."""
    info = session.platforms.get(platform)
    if info is not None and info.role == "anchor" and info.position_enu_m is not None:
        return np.tile(np.asarray(info.position_enu_m, dtype=np.float64), (time_s.shape[0], 1))
    traj = source.get(platform)
    if traj is None:
        if required:
            raise StageError(f"ranging: no {what} for platform '{platform}'")
        return np.full((time_s.shape[0], 3), np.nan)
    return traj.interpolate(time_s)


def reference_positions(session: Session, platform: str, time_s: FloatArray) -> FloatArray:
    """Reference positions at ``time_s``; NaN inside gaps of the reference
    (:meth:`Trajectory.interpolate_within`: DATA.md wants none where there is none)."""
    out = platform_positions(session, session.reference, platform, time_s, "reference", False)
    traj = session.reference.get(platform)
    info = session.platforms.get(platform)
    if traj is None or len(traj) < 2 or (info is not None and info.role == "anchor"):
        return out
    out[np.isnan(traj.interpolate_within(time_s))] = np.nan
    return out


def pair_rows(session: Session, pair: str) -> pd.DataFrame:
    """The session's ranges of one pair, by time (stable)."""
    return session.ranges.for_pair(pair).sort_values("time", kind="stable")


def pair_columns(session: Session, pair: str) -> tuple[FloatArray, FloatArray]:
    """Time and range of :func:`pair_rows` (the same rows in the same order: a stable sort
    by time, NaN last), without copying the pair's other columns into a frame."""
    frame = session.ranges.frame
    rows = session.ranges.pair_index.get(pair, np.empty(0, dtype=np.int64))
    time = frame["time"].to_numpy(dtype=np.float64)[rows]
    order = np.argsort(time, kind="stable")
    return time[order], frame["range"].to_numpy(dtype=np.float64)[rows[order]]


def observed_table(session: Session) -> pd.DataFrame:
    """``time, pair, observed, reference`` at every range epoch (module docstring)."""
    parts = []
    for pair in session.ranges.pairs:
        t, observed = pair_columns(session, pair)
        a, b = pair_members(pair)
        reference = slant_ranges(
            reference_positions(session, a, t) - reference_positions(session, b, t)
        )
        parts.append(
            pd.DataFrame(
                {
                    "time": t,
                    "pair": pair,
                    "observed": observed,
                    "reference": reference,
                }
            )
        )
    if not parts:
        return pd.DataFrame({c: [] for c in ("time", "pair", "observed", "reference")})
    return pd.concat(parts, ignore_index=True)
