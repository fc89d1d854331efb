"""Input checks and array preparation shared by the fusion EKF and the anchor LSQ."""

from __future__ import annotations

import numba
import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.model import FloatArray, Session, pair_name

__all__ = [
    "anchor_positions",
    "clean_ranges",
    "epoch_groups",
    "pair_names",
    "platform_codes",
    "range_sigma_default",
]

_REQUIRED = ("time", "from", "to", "range")


def range_sigma_default(session: Session, fallback_m: float) -> float:
    """Ranging 1-sigma for rows without one: session.toml ``[uwb] sigma`` or ``fallback_m``."""
    sigma = session.config.uwb_sigma_m
    return float(sigma) if sigma is not None and sigma > 0 else float(fallback_m)


def anchor_positions(session: Session) -> dict[str, FloatArray]:
    """ENU position (3,) of every anchor: its configured position, else its mean nav fix."""
    out: dict[str, FloatArray] = {}
    for pid, platform in session.platforms.items():
        if platform.role != "anchor":
            continue
        if platform.position_enu_m is not None:
            out[pid] = np.asarray(platform.position_enu_m, dtype=np.float64)
        elif pid in session.nav and len(session.nav[pid]) > 0:
            out[pid] = np.asarray(session.nav[pid].enu_m.mean(axis=0), dtype=np.float64)
        else:
            raise StageError(
                f"fusion: anchor '{pid}' has no position (set [platforms.{pid}] position "
                "in session.toml) and no navigation file"
            )
    return out


def clean_ranges(session: Session, ranges: pd.DataFrame, default_sigma_m: float) -> pd.DataFrame:
    """The usable range rows: columns time, from, to, range, var (m^2), in time order.

    Rows with a missing time or range (dropouts) and rows between two anchors are
    dropped; a missing or non-positive ``sigma`` becomes ``default_sigma_m``. A platform id
    that the session does not know is an error.
    """
    missing = [c for c in _REQUIRED if c not in ranges.columns]
    if missing:
        raise StageError(
            f"fusion: range table has no column '{missing[0]}' "
            "(expected columns time, from, to, range[, sigma]; found "
            f"{', '.join(map(str, ranges.columns))})"
        )
    frame = pd.DataFrame(
        {
            "time": pd.to_numeric(ranges["time"], errors="coerce").to_numpy(np.float64),
            "from": ranges["from"].astype(str).to_numpy(),
            "to": ranges["to"].astype(str).to_numpy(),
            "range": pd.to_numeric(ranges["range"], errors="coerce").to_numpy(np.float64),
        }
    )
    if "sigma" in ranges.columns:
        sigma = pd.to_numeric(ranges["sigma"], errors="coerce").to_numpy(np.float64)
    else:
        sigma = np.full(len(frame), np.nan)
    sigma = np.where(np.isfinite(sigma) & (sigma > 0), sigma, default_sigma_m)
    frame["var"] = sigma * sigma
    frame = frame[np.isfinite(frame["time"]) & np.isfinite(frame["range"])]
    ids = sorted(session.platforms)
    index = pd.Index(ids)
    codes = {}
    for column in ("from", "to"):
        code = index.get_indexer(frame[column].to_numpy())
        if (code < 0).any():
            unknown = frame[column].to_numpy()[code < 0][0]
            raise StageError(
                f"fusion: range rows name platform '{unknown}' in column '{column}', which "
                f"the session does not have (platforms: {', '.join(ids)})"
            )
        codes[column] = code
    same = codes["from"] == codes["to"]
    if same.any():
        row = frame[same].iloc[0]
        raise StageError(f"fusion: range from '{row['from']}' to itself at time {row['time']}")
    is_anchor = np.array([session.platforms[p].role == "anchor" for p in ids], dtype=bool)
    frame = frame[~(is_anchor[codes["from"]] & is_anchor[codes["to"]])]
    if not frame["time"].is_monotonic_increasing:
        frame = frame.sort_values("time", kind="stable")
    return frame.reset_index(drop=True)


def epoch_groups(time_s: FloatArray, merge_s: float) -> tuple[FloatArray, np.ndarray]:
    """Epoch times and the epoch index of each (sorted) time.

    Equal times form one epoch; with ``merge_s > 0`` an epoch opens at the first time not
    yet taken and holds every time up to ``merge_s`` after it (the epoch keeps that first
    time), e.g. one round of two-way ranging between several pairs.
    """
    if time_s.shape[0] == 0:
        return np.empty(0), np.empty(0, dtype=np.int64)
    unique, inverse = np.unique(time_s, return_inverse=True)
    if merge_s > 0 and unique.shape[0] > 1:
        group = _window_groups(unique, merge_s)
        starts = np.concatenate(([True], np.diff(group) > 0))
        return unique[starts], group[inverse].astype(np.int64)
    return unique, inverse.astype(np.int64)


def platform_codes(ids: pd.Series, order: list[str]) -> np.ndarray:
    """Position of each id in ``order`` (-1 where absent), vectorized."""
    return np.asarray(pd.Index(order).get_indexer(pd.Index(ids)), dtype=np.int64)


@numba.njit(cache=True)
def _window_groups(unique: FloatArray, merge_s: float) -> np.ndarray:
    """Group index of each sorted unique time: a group spans merge_s from its first time."""
    group = np.empty(unique.shape[0], dtype=np.int64)
    current = 0
    start = unique[0]
    for i in range(unique.shape[0]):
        if unique[i] - start > merge_s:
            current += 1
            start = unique[i]
        group[i] = current
    return group


def pair_names(first: object, second: object) -> np.ndarray:
    """:func:`pair_name` of every row of two id columns (array-likes), as an object array.

    Vectorized: each distinct (first, second) combination is named once, so a table of
    millions of ranges costs a factorization, not a Python call per row.
    """
    a = np.asarray(first, dtype=object)
    b = np.asarray(second, dtype=object)
    if a.shape[0] == 0:
        return np.empty(0, dtype=object)
    codes, uniques = pd.factorize(np.concatenate([a, b]))
    width = max(len(uniques), 1)
    key = codes[: a.shape[0]].astype(np.int64) * width + codes[a.shape[0] :]
    combos, inverse = np.unique(key, return_inverse=True)
    names = np.array(
        [pair_name(str(uniques[k // width]), str(uniques[k % width])) for k in combos],
        dtype=object,
    )
    return names[inverse.reshape(-1)]
