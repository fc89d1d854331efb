"""positions.csv in memory: every method's positions, built once into its final columns.

A day of 10 platforms is about 40 M rows. The table is made in two passes over its
pieces (one per platform and method, in the table's row order: platform, method, time):
the first finds each piece's epochs (the solution at the platform's own range epochs,
and which reference epochs exist) and counts its rows, the second computes each piece's
values and writes them into five preallocated float64 columns and the integer codes of
``platform`` and ``method`` in place. The reference is interpolated once per platform and
set of epochs, not once per piece. No per-piece frames are concatenated (that held the
table twice), and the text columns are categorical (one byte per row instead of a string
per row); the CSV bytes are the same.

With ``release=True`` each platform's trajectories are taken out of the products'
``positions`` dicts once its rows are written, so that the solutions (about 32 bytes per
row) are not held beside the finished table.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import POSITIONS_COLUMNS, FloatArray, Session, Trajectory
from coopproc.stages.base import PositionProduct

__all__ = ["own_epochs", "positions_table"]


def own_epochs(session: Session) -> dict[str, FloatArray]:
    """Per platform, the times of the ranges it took part in (sorted, unique)."""
    times = session.ranges.frame["time"].to_numpy(dtype=np.float64)
    ids, first, second = session.ranges.id_codes  # codes: no string compare per platform
    code_of = {str(platform): code for code, platform in enumerate(ids)}
    ordered = bool(np.all(times[1:] >= times[:-1]))  # as read: no sort per platform
    out = {}
    for platform in session.platform_ids:
        code = code_of.get(str(platform))
        mine = times[(first == code) | (second == code)] if code is not None else times[:0]
        if ordered and mine.shape[0]:
            mine = mine[np.concatenate(([True], mine[1:] != mine[:-1]))]
        else:
            mine = np.unique(mine)
        out[str(platform)] = mine
    return out


def _missing_rows(time_s: FloatArray, own: FloatArray) -> NDArray[np.intp]:
    """Indices of ``time_s`` not in the sorted unique ``own`` (``~np.isin``; usually none
    or a few): one binary search per epoch instead of ``isin``'s sort of both arrays."""
    if own.shape[0] == 0:
        return np.arange(time_s.shape[0])
    at = np.searchsorted(own, time_s)
    return np.flatnonzero(own[np.minimum(at, own.shape[0] - 1)] != time_s)


@dataclass(frozen=True)
class _Piece:
    """One (platform, method) block of rows (its values are computed when written)."""

    method: str
    size: int


@dataclass
class _Platform:
    """What one platform's pieces are made from; epochs and reference computed once."""

    session: Session
    products: Mapping[str, PositionProduct]
    platform: str
    basis: str | None  # the solution whose epochs the reference and nav rows take
    ref: Trajectory | None
    missing: dict[str, NDArray[np.intp] | None]
    _times: dict[str, FloatArray]
    _truth: list[tuple[FloatArray, FloatArray]]

    def times(self, method: str) -> FloatArray:
        """The method's epochs (at the platform's own epochs), in the solution's order."""
        if method not in self._times:
            t = self.products[method].positions[self.platform].time_s
            drop = self.missing[method]
            if drop is not None and drop.shape[0]:
                keep = np.ones(t.shape[0], dtype=bool)
                keep[drop] = False
                t = t[keep]
            self._times[method] = t
        return self._times[method]

    def truth(self, time_s: FloatArray) -> FloatArray:
        """``ref.interpolate_within(time_s)``, once per distinct epochs (and gap limit)."""
        for t, truth in self._truth:
            if t is time_s or (t.shape == time_s.shape and np.array_equal(t, time_s)):
                return truth
        assert self.ref is not None
        truth = self.ref.interpolate_within(time_s)
        self._truth.append((time_s, truth))
        return truth

    def reference_ok(self) -> NDArray[np.bool_]:
        assert self.basis is not None
        return np.all(np.isfinite(self.truth(self.times(self.basis))), axis=1)

    def values(self, method: str) -> tuple[FloatArray, FloatArray, FloatArray]:
        """A piece's time, (n, 3) east/north/up and horizontal error, in solution order."""
        if method == "reference":
            ok = self.reference_ok()
            t = self.times(str(self.basis))
            return t[ok], self.truth(t)[ok], np.full(int(ok.sum()), np.nan)
        if method == "nav":
            t = self.times(str(self.basis))
            enu = self.session.nav[self.platform].interpolate(t)
        else:
            t = self.times(method)
            enu = self.products[method].positions[self.platform].enu_m
            drop = self.missing[method]
            if drop is not None and drop.shape[0]:
                enu = np.delete(enu, drop, axis=0)
        if self.ref is None:
            return t, enu, np.full(t.shape[0], np.nan)
        truth = self.truth(t)
        return t, enu, np.hypot(enu[:, 0] - truth[:, 0], enu[:, 1] - truth[:, 1])

    def forget(self) -> None:
        self._times.clear()
        self._truth.clear()


def _platform_pieces(
    session: Session,
    products: Mapping[str, PositionProduct],
    own: Mapping[str, FloatArray] | None,
    basis: str | None,
    platform: str,
) -> tuple[list[_Piece], _Platform]:
    """The platform's pieces in row order (method by name), counted, not filled."""
    ref = session.reference.get(platform)
    ref = ref if ref is not None and len(ref) >= 2 else None
    missing: dict[str, NDArray[np.intp] | None] = {}
    for method, product in products.items():
        traj = product.positions.get(platform)
        if traj is not None:
            mine = None if own is None else own.get(platform, np.empty(0))
            missing[method] = None if mine is None else _missing_rows(traj.time_s, mine)
    # the reference and own navigation at the epochs of the basis solution; a tag the
    # basis leaves out has its reference at its first method's epochs
    like = basis if basis in missing else None
    if like is None and session.platforms[platform].role == "tag":
        like = next(iter(missing), None)
    source = _Platform(session, products, platform, like, ref, missing, {}, [])
    found = {m: _Piece(m, len(source.times(m))) for m in missing}
    if like is not None:
        if ref is not None:
            found["reference"] = _Piece("reference", int(source.reference_ok().sum()))
        if like == basis and platform in session.nav:  # a tag: no navigation of its own
            found["nav"] = _Piece("nav", len(source.times(like)))
    source.forget()  # pass 1 keeps counts only
    return [found[m] for m in sorted(found)], source


def positions_table(
    session: Session,
    products: Mapping[str, PositionProduct],
    output: str,
    *,
    release: bool = False,
) -> pd.DataFrame:
    """positions.csv: the reference and the own navigation at the epochs of the observed
    fusion (else of the first position method), then every position method; rows by
    platform, method, time (see the module docstring for how it is built; ``release``
    empties the products' ``positions`` dicts as it goes)."""
    own = own_epochs(session) if output == "ranges" else None
    methods = list(products)
    # the reference and own navigation at the epochs of the observed fusion, else of the
    # first position method (a method without platforms gives the next one's, as before)
    basis = next((m for m in ("observed", *methods) if m in products), None)
    if basis is not None and not products[basis].positions:
        basis = methods[0]
    platforms_in = sorted({p for product in products.values() for p in product.positions})
    plan = [
        (platform, _platform_pieces(session, products, own, basis, platform))
        for platform in platforms_in
    ]  # pass 1: each piece's epochs and rows
    kept = [(p, [c for c in pieces if c.size], e) for p, (pieces, e) in plan]
    kept = [(p, pieces, e) for p, pieces, e in kept if pieces]
    if not kept:
        return pd.DataFrame(columns=list(POSITIONS_COLUMNS))
    total = sum(c.size for _, pieces, _ in kept for c in pieces)
    platforms = [p for p, _, _ in kept]
    method_names = sorted({c.method for _, pieces, _ in kept for c in pieces})
    columns = {name: np.empty(total) for name in ("time", "east", "north", "up", "error_h")}
    platform_code: np.ndarray = np.empty(total, dtype=_code_dtype(len(platforms)))
    method_code: np.ndarray = np.empty(total, dtype=_code_dtype(len(method_names)))
    start = 0
    for code, (platform, pieces, source) in enumerate(kept):  # pass 2: fill in place
        for piece in pieces:
            time_s, enu, error_h = source.values(piece.method)
            n = piece.size
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
            method_code[rows] = method_names.index(piece.method)
            start += n
        platform_code[start - sum(c.size for c in pieces) : start] = code
        source.forget()
        if release:
            _release(products, platform)
    if release:  # platforms without rows too
        for platform, _ in plan:
            _release(products, platform)
    data: dict[str, object] = {
        "time": columns["time"],
        "platform": pd.Categorical.from_codes(platform_code, categories=pd.Index(platforms)),
        "method": pd.Categorical.from_codes(method_code, categories=pd.Index(method_names)),
        "east": columns["east"],
        "north": columns["north"],
        "up": columns["up"],
        "error_h": columns["error_h"],
    }
    return pd.DataFrame(data, columns=list(POSITIONS_COLUMNS), copy=False)


def _release(products: Mapping[str, PositionProduct], platform: str) -> None:
    for product in products.values():
        if isinstance(product.positions, dict):
            product.positions.pop(platform, None)


def _code_dtype(n: int) -> type:
    return np.int8 if n < 127 else np.int16 if n < 32767 else np.int32
