"""Input checks and array preparation shared by the method families: the fusion EKF, the
anchors' methods, the INS, GNSS and odometer filters."""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.errors import StageError
from coopproc.model import FloatArray, Session, pair_name

__all__ = [
    "RangeRows",
    "anchor_positions",
    "clean_range_rows",
    "clean_range_rows_indexed",
    "clean_ranges",
    "epoch_groups",
    "id_column",
    "nav_at_epochs",
    "nav_points",
    "nav_samples",
    "pair_names",
    "platform_codes",
    "range_sigma_default",
    "row_sigmas",
    "shared_nav",
]

_REQUIRED = ("time", "from", "to", "range")

IntArray = NDArray[np.int64]
CodeArray = NDArray[np.int32]

#: The last navigation at the epochs inside :func:`shared_nav` (None: outside any).
_SHARED_NAV: contextvars.ContextVar[
    list[tuple[Session, tuple[str, ...], FloatArray, FloatArray]] | None
] = contextvars.ContextVar("coopproc_fusion_shared_nav", default=None)


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


@dataclass(frozen=True)
class RangeRows:
    """The usable range rows as arrays (:func:`clean_range_rows`), in time order.

    ``from_code`` / ``to_code`` index ``ids``, the session's platform ids sorted: the
    fusion works on these codes, never on a string per row.
    """

    time: FloatArray
    range: FloatArray
    var: FloatArray  # m^2
    from_code: CodeArray
    to_code: CodeArray
    ids: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.time.shape[0])

    def take(self, index: np.ndarray) -> RangeRows:
        """The rows at ``index`` (positions), in that order."""
        return RangeRows(
            self.time[index], self.range[index], self.var[index], self.from_code[index],
            self.to_code[index], self.ids,
        )  # fmt: skip

    def id_column(self, codes: CodeArray) -> pd.api.extensions.ExtensionArray:
        """The platform ids of ``codes`` as a string column (one take, no per-row str)."""
        return id_column(self.ids, codes)

    def frame(self) -> pd.DataFrame:
        """Columns time, from, to, range, var (what :func:`clean_ranges` returns)."""
        return pd.DataFrame(
            {
                "time": self.time,
                "from": self.id_column(self.from_code),
                "to": self.id_column(self.to_code),
                "range": self.range,
                "var": self.var,
            }
        )


def id_column(ids: tuple[str, ...], codes: CodeArray) -> pd.api.extensions.ExtensionArray:
    """The ids ``ids[codes]`` as a string column (one take, no per-row str)."""
    return pd.array(list(ids), dtype="str").take(codes)


def clean_ranges(session: Session, ranges: pd.DataFrame, default_sigma_m: float) -> pd.DataFrame:
    """The usable range rows: columns time, from, to, range, var (m^2), in time order.

    Rows with a missing time or range (dropouts) and rows between two anchors are
    dropped; a missing or non-positive ``sigma`` becomes ``default_sigma_m``. A platform id
    that the session does not know is an error.
    """
    return clean_range_rows(session, ranges, default_sigma_m).frame()


def clean_range_rows(session: Session, ranges: pd.DataFrame, default_sigma_m: float) -> RangeRows:
    """:func:`clean_ranges` as arrays with platform codes (:class:`RangeRows`)."""
    return clean_range_rows_indexed(session, ranges, default_sigma_m)[0]


def row_sigmas(ranges: pd.DataFrame, default_sigma_m: float) -> FloatArray:
    """Each row's ranging 1-sigma: its ``sigma``, else (missing, non-positive, no column)
    ``default_sigma_m``."""
    if "sigma" in ranges.columns:
        sigma = pd.to_numeric(ranges["sigma"], errors="coerce").to_numpy(np.float64)
    else:
        sigma = np.full(len(ranges), np.nan)
    return np.where(np.isfinite(sigma) & (sigma > 0), sigma, default_sigma_m)


def clean_range_rows_indexed(
    session: Session, ranges: pd.DataFrame, default_sigma_m: float
) -> tuple[RangeRows, IntArray]:
    """:func:`clean_range_rows` and each clean row's position in ``ranges`` (so that a
    range set differing only in its sigma or range values maps onto the same rows)."""
    missing = [c for c in _REQUIRED if c not in ranges.columns]
    if missing:
        raise StageError(
            f"fusion: range table has no column '{missing[0]}' "
            "(expected columns time, from, to, range[, sigma]; found "
            f"{', '.join(map(str, ranges.columns))})"
        )
    time = pd.to_numeric(ranges["time"], errors="coerce").to_numpy(np.float64)
    value = pd.to_numeric(ranges["range"], errors="coerce").to_numpy(np.float64)
    sigma = row_sigmas(ranges, default_sigma_m)
    keep = np.flatnonzero(np.isfinite(time) & np.isfinite(value))
    ids = sorted(session.platforms)
    codes = {}
    for column in ("from", "to"):
        code, raw, names = _id_codes(ranges[column], ids)
        code = code[keep]
        if (code < 0).any():
            unknown = names[raw[keep[np.flatnonzero(code < 0)[0]]]]
            raise StageError(
                f"fusion: range rows name platform '{unknown}' in column '{column}', which "
                f"the session does not have (platforms: {', '.join(ids)})"
            )
        codes[column] = code
    same = codes["from"] == codes["to"]
    if same.any():
        row = int(np.flatnonzero(same)[0])
        raise StageError(
            f"fusion: range from '{ids[codes['from'][row]]}' to itself at time {time[keep[row]]}"
        )
    is_anchor = np.array([session.platforms[p].role == "anchor" for p in ids], dtype=bool)
    pick = ~(is_anchor[codes["from"]] & is_anchor[codes["to"]])
    if keep.shape[0] < time.shape[0]:  # (copies only when rows are dropped)
        time, value, sigma = time[keep], value[keep], sigma[keep]
    source = keep.astype(np.int64, copy=False)
    del keep
    rows = RangeRows(time, value, sigma * sigma, codes["from"], codes["to"], tuple(ids))
    del time, value, sigma
    if not pick.all():
        at = np.flatnonzero(pick)
        rows, source = rows.take(at), source[at]
    if rows.time.shape[0] > 1 and not bool(np.all(rows.time[1:] >= rows.time[:-1])):
        order = np.argsort(rows.time, kind="stable")
        rows, source = rows.take(order), source[order]
    return rows, source


def _id_codes(values: pd.Series, order: list[str]) -> tuple[CodeArray, IntArray, list[str]]:
    """Position in ``order`` of each value's ``str`` (-1 where absent), each row's code into
    the distinct strings, and those strings: one factorization, one ``str`` per distinct
    value (not per row)."""
    raw, uniques = pd.factorize(values, use_na_sentinel=False)
    names = [str(u) for u in uniques]
    lut = pd.Index(order).get_indexer(pd.Index(names, dtype=object))
    return lut.astype(np.int32)[raw], raw, names


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


def nav_at_epochs(
    session: Session, moving: list[str], epochs: FloatArray, axes: int = 3
) -> FloatArray:
    """(P, K, axes): each moving platform's own navigation interpolated at the epochs.

    What stacking ``session.nav[p].interpolate(epochs)`` gives (the same ``np.interp``),
    written into one array: no per-platform (K, 3) copies next to it (at 20 platforms x
    1 h the array is 320 MB). ``axes``: the first east/north[/up] axes only (the 2D fusion
    needs no height at every epoch: :func:`nav_points` gives it where it is read, the same
    ``np.interp`` values). Inside :func:`shared_nav` the last result is given again to a
    call with the same session, platforms, epochs and axes (read only: nobody writes to it).
    """
    shared = _SHARED_NAV.get()
    if shared:
        was_session, was_moving, was_epochs, was_nav = shared[0]
        if (
            was_session is session
            and was_moving == tuple(moving)
            and was_nav.shape[2] == axes
            and was_epochs.shape == epochs.shape
            and np.array_equal(was_epochs, epochs)
        ):
            return was_nav
    out = np.empty((len(moving), epochs.shape[0], axes))
    for p, pid in enumerate(moving):
        traj = session.nav[pid]
        for axis in range(axes):
            out[p, :, axis] = np.interp(epochs, traj.time_s, traj.enu_m[:, axis])
        outside = (epochs < traj.time_s[0]) | (epochs > traj.time_s[-1])
        if outside.any():
            out[p, outside] = np.nan
    if shared is not None:
        shared[:] = [(session, tuple(moving), epochs, out)]
    return out


def nav_points(session: Session, pid: str, times: FloatArray, axes: range) -> FloatArray:
    """(n, len(axes)): ``pid``'s navigation at ``times`` on ``axes``, what
    :func:`nav_at_epochs` holds there (the same ``np.interp``, element by element)."""
    traj = session.nav[pid]
    out = np.empty((times.shape[0], len(axes)))
    for j, axis in enumerate(axes):
        out[:, j] = np.interp(times, traj.time_s, traj.enu_m[:, axis])
    outside = (times < traj.time_s[0]) | (times > traj.time_s[-1])
    if outside.any():
        out[outside] = np.nan
    return out


def nav_samples(
    session: Session, moving: list[str], axes: int
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Every moving platform's navigation samples, concatenated for the compiled filter
    (:func:`~coopproc.stages.fusion.ekf.nav_at`): times (S,), east/north[/up] (S, axes)
    and the platforms' bounds (P + 1). At 10 Hz navigation this is about a third of the
    navigation at every range epoch of 10 platforms, and less the more platforms."""
    times = [session.nav[pid].time_s for pid in moving]
    ptr = np.concatenate(([0], np.cumsum([t.shape[0] for t in times]))).astype(np.int64)
    nav_t = np.concatenate(times).astype(np.float64, copy=False)
    nav_v = np.empty((int(ptr[-1]), axes))
    for p, pid in enumerate(moving):
        nav_v[ptr[p] : ptr[p + 1]] = session.nav[pid].enu_m[:, :axes]
    return nav_t, nav_v, ptr


@contextlib.contextmanager
def shared_nav() -> Iterator[None]:
    """Share :func:`nav_at_epochs` between the fusions of the block (one context, e.g. one
    thread): the self-calibration fuses one range set several times (drift rounds, the
    platform-bias iteration) with the same range times, so the same (P, K, 3) navigation
    at the epochs. Only the last one is kept, and only until the block ends."""
    token = _SHARED_NAV.set([])
    try:
        yield
    finally:
        _SHARED_NAV.reset(token)


def platform_codes(ids: pd.Series, order: list[str]) -> np.ndarray:
    """Position of each id in ``order`` (-1 where absent), vectorized: one factorization
    and a lookup per distinct id (hashing millions of strings against an index is slow)."""
    raw, uniques = pd.factorize(ids)  # a missing id: code -1, absent from order
    lut = np.append(pd.Index(order).get_indexer(uniques), -1)
    return np.asarray(lut[raw], dtype=np.int64)


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

    Vectorized: each column is factorized on its own (a string column is never turned
    into a Python string per row) and each distinct (first, second) combination is named
    once, so a table of millions of ranges costs two factorizations, not a call per row.
    """
    a = first if isinstance(first, pd.Series | pd.Index | np.ndarray) else np.asarray(first)
    b = second if isinstance(second, pd.Series | pd.Index | np.ndarray) else np.asarray(second)
    if len(a) == 0:
        return np.empty(0, dtype=object)
    code_a, uniq_a = pd.factorize(a, use_na_sentinel=False)
    code_b, uniq_b = pd.factorize(b, use_na_sentinel=False)
    width = max(len(uniq_b), 1)
    key = code_a.astype(np.int64) * width + code_b
    combos, inverse = np.unique(key, return_inverse=True)
    names = np.array(
        [pair_name(str(uniq_a[k // width]), str(uniq_b[k % width])) for k in combos],
        dtype=object,
    )
    return names[inverse.reshape(-1)]
