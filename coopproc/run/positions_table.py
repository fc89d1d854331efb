"""positions.csv in memory: every method's positions, built once into its final columns.

A day of 10 platforms is about 40 M rows. The table is made in two passes over its
pieces (one per platform and method, in the table's row order: platform, method, time):
the first counts each piece's rows, the second fills five preallocated float64 columns
and the integer codes of ``platform`` and ``method`` in place. No per-piece frames are
concatenated (that held the table twice), and the text columns are categorical (one
byte per row instead of a string per row); the CSV bytes are the same.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from coopproc.model import POSITIONS_COLUMNS, FloatArray, Session, Trajectory
from coopproc.stages.base import PositionProduct

__all__ = ["own_epochs", "positions_table"]

#: A piece's rows: time, (n, 3) east/north/up, horizontal error.
_Rows = tuple[FloatArray, FloatArray, FloatArray]


@dataclass(frozen=True)
class _Piece:
    platform: str
    method: str
    rows: Callable[[], _Rows]


def own_epochs(session: Session) -> dict[str, FloatArray]:
    """Per platform, the times of the ranges it took part in (sorted, unique)."""
    frame = session.ranges.frame
    times = frame["time"].to_numpy(dtype=np.float64)
    ids = pd.Index(list(session.platform_ids))
    first = ids.get_indexer(pd.Index(frame["from"]))  # codes: no string compare per platform
    second = ids.get_indexer(pd.Index(frame["to"]))
    out = {}
    for code, platform in enumerate(ids):
        involved = (first == code) | (second == code)
        out[str(platform)] = np.unique(times[involved])
    return out


def _at_own_epochs(traj: Trajectory, own: Mapping[str, FloatArray] | None) -> Trajectory:
    """The solution only at the epochs of the platform's own ranges (``positions_at =
    "ranges"``): the fusion runs at every range time of the session (with staggered pair
    polling, many per second), but a platform's position is reported, and scored, at
    the epochs where it was ranged, as paper 000's 1 Hz cooperative updates are."""
    if own is None:
        return traj
    keep = np.isin(traj.time_s, own.get(traj.platform, np.empty(0)))
    return Trajectory(traj.platform, traj.time_s[keep], traj.enu_m[keep])


def _error_h(session: Session, platform: str, time_s: FloatArray, enu_m: FloatArray) -> FloatArray:
    ref = session.reference.get(platform)
    if ref is None or len(ref) < 2:
        return np.full(len(time_s), np.nan)
    truth = ref.interpolate_within(time_s)
    return np.hypot(enu_m[:, 0] - truth[:, 0], enu_m[:, 1] - truth[:, 1])


def _method_rows(session: Session, traj: Callable[[], Trajectory], platform: str) -> _Rows:
    t = traj()
    return t.time_s, t.enu_m, _error_h(session, platform, t.time_s, t.enu_m)


def _nav_rows(session: Session, basis: Callable[[], Trajectory], platform: str) -> _Rows:
    """The platform's own navigation at the epochs of the basis solution."""
    t = basis().time_s
    enu = session.nav[platform].interpolate(t)
    return t, enu, _error_h(session, platform, t, enu)


def _reference_rows(session: Session, like: Callable[[], Trajectory], platform: str) -> _Rows:
    """The reference at the epochs of ``like`` (an extension of DATA.md's positions.csv;
    epochs without reference are left out)."""
    t = like().time_s
    pos = session.reference[platform].interpolate_within(t)
    ok = np.all(np.isfinite(pos), axis=1)
    return t[ok], pos[ok], np.full(int(ok.sum()), np.nan)


def _pieces(
    session: Session, products: Mapping[str, PositionProduct], output: str
) -> Iterator[_Piece]:
    """The table's pieces in row order (platform, then method, by name)."""
    own = own_epochs(session) if output == "ranges" else None

    def solution(method: str, platform: str) -> Callable[[], Trajectory]:
        return lambda: _at_own_epochs(products[method].positions[platform], own)

    # the reference and own navigation at the epochs of the observed fusion, else of the
    # first position method (a method without platforms gives the next one's, as before)
    methods = list(products)
    basis = next((m for m in ("observed", *methods) if m in products), None)
    if basis is not None and not products[basis].positions:
        basis = methods[0]
    found: dict[tuple[str, str], _Piece] = {}

    def has_reference(platform: str) -> bool:
        ref = session.reference.get(platform)
        return ref is not None and len(ref) >= 2

    if basis is not None:
        for platform in products[basis].positions:
            like = solution(basis, platform)
            if has_reference(platform):
                found[platform, "reference"] = _Piece(
                    platform, "reference", _bind(_reference_rows, session, like, platform)
                )
            if platform in session.nav:  # a tag: no navigation of its own
                found[platform, "nav"] = _Piece(
                    platform, "nav", _bind(_nav_rows, session, like, platform)
                )
        for method in methods:  # tags the basis leaves out: their first method's epochs
            for platform in products[method].positions:
                if (
                    session.platforms[platform].role == "tag"
                    and (platform, "reference") not in found
                    and has_reference(platform)
                ):
                    like = solution(method, platform)
                    found[platform, "reference"] = _Piece(
                        platform, "reference", _bind(_reference_rows, session, like, platform)
                    )
    for method in methods:
        for platform in products[method].positions:
            found[platform, method] = _Piece(
                platform, method, _bind(_method_rows, session, solution(method, platform), platform)
            )
    for key in sorted(found):
        yield found[key]


def _bind(
    make: Callable[[Session, Callable[[], Trajectory], str], _Rows],
    session: Session,
    traj: Callable[[], Trajectory],
    platform: str,
) -> Callable[[], _Rows]:
    return lambda: make(session, traj, platform)


def positions_table(
    session: Session, products: Mapping[str, PositionProduct], output: str
) -> pd.DataFrame:
    """positions.csv: the reference and the own navigation at the epochs of the observed
    fusion (else of the first position method), then every position method; rows by
    platform, method, time (see the module docstring for how it is built)."""
    pieces = list(_pieces(session, products, output))
    sizes = [len(piece.rows()[0]) for piece in pieces]  # pass 1: the rows of each piece
    kept = [(piece, n) for piece, n in zip(pieces, sizes, strict=True) if n]
    if not kept:
        return pd.DataFrame(columns=list(POSITIONS_COLUMNS))
    total = sum(n for _, n in kept)
    platforms = sorted({piece.platform for piece, _ in kept})
    methods = sorted({piece.method for piece, _ in kept})
    columns = {name: np.empty(total) for name in ("time", "east", "north", "up", "error_h")}
    platform_code: np.ndarray = np.empty(total, dtype=_code_dtype(len(platforms)))
    method_code: np.ndarray = np.empty(total, dtype=_code_dtype(len(methods)))
    start = 0
    for piece, n in kept:  # pass 2: fill the columns in place, piece by piece
        time_s, enu, error_h = piece.rows()
        rows = slice(start, start + n)
        order = None
        if n > 1 and not bool(np.all(time_s[1:] >= time_s[:-1])):
            order = np.argsort(time_s, kind="stable")  # rows by time, ties as they came
        for name, values in (
            ("time", time_s),
            ("east", enu[:, 0]),
            ("north", enu[:, 1]),
            ("up", enu[:, 2]),
            ("error_h", error_h),
        ):
            columns[name][rows] = values if order is None else values[order]
        platform_code[rows] = platforms.index(piece.platform)
        method_code[rows] = methods.index(piece.method)
        start += n
    data: dict[str, object] = {
        "time": columns["time"],
        "platform": pd.Categorical.from_codes(platform_code, categories=pd.Index(platforms)),
        "method": pd.Categorical.from_codes(method_code, categories=pd.Index(methods)),
        "east": columns["east"],
        "north": columns["north"],
        "up": columns["up"],
        "error_h": columns["error_h"],
    }
    return pd.DataFrame(data, columns=list(POSITIONS_COLUMNS), copy=False)


def _code_dtype(n: int) -> type:
    return np.int8 if n < 127 else np.int16 if n < 32767 else np.int32
