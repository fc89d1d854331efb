"""positions.csv in memory: every method's positions, built once into its final columns.

A day of 10 platforms is about 40 M rows. The table is written in one pass over its
pieces (one per platform and method, in the table's row order: platform, method, time)
into five preallocated float64 columns and the integer codes of ``platform`` and
``method``. The columns are allocated for an upper bound of the rows (every solution
epoch, and the reference and navigation at every basis epoch); the rows a piece leaves
out (epochs that are not the platform's own, epochs without reference) are the unused
tail, which is never written, so never takes memory, and the table is a view of the
written rows. The reference is interpolated once per platform and set of epochs, not
once per piece. No per-piece frames are concatenated (that held the table twice), and
the text columns are categorical (one byte per row instead of a string per row); the
CSV bytes are the same.

With ``release=True`` each platform's trajectories are taken out of the products'
``positions`` dicts once its rows are written, so that the solutions (about 32 bytes per
row) are not held beside the finished table; given :class:`PositionSamples` (the
navigation and reference it reads, taken from the session before the session let go of
its samples), its navigation and reference go too (at a day of 10 platforms: 0.8 GB,
freed as the table's 1.6 GB fill, issue 11).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.memory import gives_back
from coopproc.model import POSITIONS_COLUMNS, FloatArray, Platform, Session, Trajectory
from coopproc.stages.base import PositionProduct

__all__ = ["PositionSamples", "own_epochs", "positions_table"]


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


@dataclass
class PositionSamples:
    """What positions.csv reads of the session's samples: each platform's navigation and
    reference and its own range epochs (``output`` "ranges"; None: every epoch). Its own
    dicts: :func:`positions_table` with ``release=True`` empties them as it goes, and the
    session may let go of its samples once this is taken."""

    platforms: Mapping[str, Platform]
    nav: dict[str, Trajectory]
    reference: dict[str, Trajectory]
    own: dict[str, FloatArray] | None

    @classmethod
    def of(cls, session: Session, output: str) -> PositionSamples:
        own = own_epochs(session) if output == "ranges" else None
        return cls(session.platforms, dict(session.nav), dict(session.reference), own)


def _missing_rows(time_s: FloatArray, own: FloatArray) -> NDArray[np.intp]:
    """Indices of ``time_s`` not in the sorted unique ``own`` (``~np.isin``; usually none
    or a few): a merge of the two when ``time_s`` is increasing (a solution's epochs),
    else one binary search per epoch, instead of ``isin``'s sort of both arrays."""
    if own.shape[0] == 0:
        return np.arange(time_s.shape[0])
    if time_s.shape[0] > 1 and bool(np.all(time_s[1:] > time_s[:-1])):
        found = _found_merged(time_s, own)
    else:
        at = np.searchsorted(own, time_s)
        found = own[np.minimum(at, own.shape[0] - 1)] == time_s
    return np.flatnonzero(~found)


@numba.njit(cache=True)
def _found_merged(time_s: FloatArray, own: FloatArray) -> NDArray[np.bool_]:  # pragma: no cover
    """Whether each of the increasing ``time_s`` is in the sorted ``own`` (NaN last)."""
    found = np.zeros(time_s.shape[0], dtype=np.bool_)
    j = 0
    m = own.shape[0]
    for i in range(time_s.shape[0]):
        t = time_s[i]
        while j < m and own[j] < t:
            j += 1
        found[i] = j < m and own[j] == t
    return found


@dataclass
class _Platform:
    """What one platform's pieces are made from; epochs and reference computed once."""

    nav: Trajectory | None  # the platform's own navigation
    products: Mapping[str, PositionProduct]
    own: FloatArray | None  # the platform's own range epochs (None: every epoch)
    platform: str
    basis: str | None  # the solution whose epochs the reference and nav rows take
    ref: Trajectory | None
    _rows: dict[str, tuple[FloatArray, NDArray[np.intp] | None]]
    _truth: list[tuple[FloatArray, FloatArray]]
    #: the pieces made of each solution so far: methods with the same solution (a
    #: processed set that reused the observed fusion) take its piece, not a new one
    _made: list[tuple[Trajectory, tuple[FloatArray, FloatArray, FloatArray]]] = field(
        default_factory=list
    )

    def rows(self, method: str) -> tuple[FloatArray, NDArray[np.intp] | None]:
        """The method's epochs at the platform's own epochs, in the solution's order, and
        the solution rows left out (None: none)."""
        if method not in self._rows:
            t = self.products[method].positions[self.platform].time_s
            drop = None if self.own is None else _missing_rows(t, self.own)
            if drop is not None and drop.shape[0]:
                keep = np.ones(t.shape[0], dtype=bool)
                keep[drop] = False
                t = t[keep]
            self._rows[method] = (t, drop)
        return self._rows[method]

    def truth(self, time_s: FloatArray) -> FloatArray:
        """``ref.interpolate_within(time_s)``, once per distinct epochs."""
        for t, truth in self._truth:
            if t is time_s or (t.shape == time_s.shape and np.array_equal(t, time_s)):
                return truth
        assert self.ref is not None
        truth = self.ref.interpolate_within(time_s)
        self._truth.append((time_s, truth))
        return truth

    def forget(self) -> None:
        self._rows.clear()
        self._truth.clear()
        self._made.clear()

    def values(self, method: str) -> tuple[FloatArray, FloatArray, FloatArray]:
        """A piece's time, (n, 3) east/north/up and horizontal error, in solution order."""
        if method == "reference":
            t = self.rows(str(self.basis))[0]
            truth = self.truth(t)
            ok = np.all(np.isfinite(truth), axis=1)
            return t[ok], truth[ok], np.full(int(ok.sum()), np.nan)
        if method == "nav":
            t = self.rows(str(self.basis))[0]
            assert self.nav is not None
            enu = self.nav.interpolate(t)
        else:
            solution = self.products[method].positions[self.platform]
            made = next((piece for traj, piece in self._made if traj is solution), None)
            if made is not None:
                return made
            t, drop = self.rows(method)
            enu = solution.enu_m
            if drop is not None and drop.shape[0]:
                enu = np.delete(enu, drop, axis=0)
        if self.ref is None:
            piece = t, enu, np.full(t.shape[0], np.nan)
        else:
            truth = self.truth(t)
            piece = t, enu, np.hypot(enu[:, 0] - truth[:, 0], enu[:, 1] - truth[:, 1])
        if method != "nav":
            self._made.append((solution, piece))
        return piece


def _platform_pieces(
    samples: PositionSamples,
    products: Mapping[str, PositionProduct],
    basis: str | None,
    platform: str,
) -> tuple[list[str], _Platform, int]:
    """The platform's pieces (methods by name, in row order), where their values come
    from, and an upper bound of their rows."""
    ref = samples.reference.get(platform)
    ref = ref if ref is not None and len(ref) >= 2 else None
    lengths = {
        m: len(p.positions[platform]) for m, p in products.items() if platform in p.positions
    }
    # the reference and own navigation at the epochs of the basis solution; a tag the
    # basis leaves out has its reference at its first method's epochs
    like = basis if basis in lengths else None
    if like is None and samples.platforms[platform].role == "tag":
        like = next(iter(lengths), None)
    mine = None if samples.own is None else samples.own.get(platform, np.empty(0))
    nav = samples.nav.get(platform)
    source = _Platform(nav, products, mine, platform, like, ref, {}, [])
    methods = list(lengths)
    if like is not None:
        if ref is not None:
            methods.append("reference")
        if like == basis and nav is not None:  # a tag: no navigation of its own
            methods.append("nav")
    bound = sum(lengths.values()) + (len(methods) - len(lengths)) * lengths.get(str(like), 0)
    return sorted(methods), source, bound


@gives_back  # before the next platform's rows take more (~20 MB columns at a day)
def _let_go(
    products: Mapping[str, PositionProduct],
    samples: PositionSamples,
    source: _Platform,
    pid: str,
) -> None:
    """Platform ``pid``'s trajectories, navigation and reference, once its rows are in."""
    _release(products, pid)
    samples.nav.pop(pid, None)
    samples.reference.pop(pid, None)
    source.nav = source.ref = None


def positions_table(
    session: Session | PositionSamples,
    products: Mapping[str, PositionProduct],
    output: str,
    *,
    release: bool = False,
) -> pd.DataFrame:
    """positions.csv: the reference and the own navigation at the epochs of the observed
    fusion (else of the first position method), then every position method; rows by
    platform, method, time (see the module docstring for how it is built; ``release``
    empties the products' ``positions`` dicts as it goes, and the navigation and reference
    of given :class:`PositionSamples`)."""
    samples = session
    if not isinstance(samples, PositionSamples):
        samples = PositionSamples.of(samples, output)
    methods = list(products)
    # the reference and own navigation at the epochs of the observed fusion, else of the
    # first position method (a method without platforms gives the next one's, as before)
    basis = next((m for m in ("observed", *methods) if m in products), None)
    if basis is not None and not products[basis].positions:
        basis = methods[0]
    platforms = sorted({p for product in products.values() for p in product.positions})
    plan = [_platform_pieces(samples, products, basis, p) for p in platforms]
    names = sorted({m for pieces, _, _ in plan for m in pieces})
    bound = sum(b for _, _, b in plan)
    columns = {name: np.empty(bound) for name in ("time", "east", "north", "up", "error_h")}
    platform_code: np.ndarray = np.empty(bound, dtype=_code_dtype(len(platforms)))
    method_code: np.ndarray = np.empty(bound, dtype=_code_dtype(len(names)))
    used_platforms: set[int] = set()
    used_methods: set[int] = set()
    start = 0
    for code, (pieces, source, _) in enumerate(plan):  # fill in place, piece by piece
        first = start
        for method in pieces:
            time_s, enu, error_h = source.values(method)
            n = time_s.shape[0]
            if n == 0:
                continue
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
            method_code[rows] = names.index(method)
            used_methods.add(names.index(method))
            start += n
        platform_code[first:start] = code
        if start > first:
            used_platforms.add(code)
        source.forget()  # its epochs and reference at them go now
        if release:
            _let_go(products, samples, source, platforms[code])
    if start == 0:
        return pd.DataFrame(columns=list(POSITIONS_COLUMNS))
    platform_code, platform_names = _used(platform_code[:start], platforms, used_platforms)
    method_code, method_names = _used(method_code[:start], names, used_methods)
    data: dict[str, object] = {
        "time": columns["time"][:start],
        "platform": pd.Categorical.from_codes(platform_code, categories=pd.Index(platform_names)),
        "method": pd.Categorical.from_codes(method_code, categories=pd.Index(method_names)),
        "east": columns["east"][:start],
        "north": columns["north"][:start],
        "up": columns["up"][:start],
        "error_h": columns["error_h"][:start],
    }
    return pd.DataFrame(data, columns=list(POSITIONS_COLUMNS), copy=False)


def _used(codes: np.ndarray, names: list[str], used: set[int]) -> tuple[np.ndarray, list[str]]:
    """The codes and categories of the names that have rows (a piece without rows gives
    no category, as the table always did)."""
    if len(used) == len(names):
        return codes, names
    kept = sorted(used)
    remap = np.full(len(names), -1, dtype=np.int64)
    remap[kept] = np.arange(len(kept))
    return remap[codes].astype(_code_dtype(len(kept))), [names[i] for i in kept]


def _release(products: Mapping[str, PositionProduct], platform: str) -> None:
    for product in products.values():
        if isinstance(product.positions, dict):
            product.positions.pop(platform, None)


def _code_dtype(n: int) -> type:
    return np.int8 if n < 127 else np.int16 if n < 32767 else np.int32
