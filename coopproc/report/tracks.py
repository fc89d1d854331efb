"""The evaluation epochs of ``positions.csv``, platform by platform and method by method.

What :func:`coopproc.report.evaluation.matched_tracks` yields (definitions in
:mod:`coopproc.report.evaluation`), found by integer codes, not by string comparisons: a
day of 10 platforms is about 40 M rows, and a pandas ``groupby`` with a boolean mask per
method copied every group several times. Here the table is read in place: its ``time``,
``east``, ``north``, ``up`` and ``error_h`` columns as numpy views, ``platform`` and
``method`` as codes (a categorical's own codes; a text column is factorized once). A table
whose rows come grouped by platform and method (as ``coopproc run`` builds it and writes
it) is cut into slices; any other row order is grouped by one stable argsort of the codes,
which keeps the rows' order within a group as pandas did. Within a group the rows are
ordered by time (stable). The reference at a method's epochs is interpolated once per
platform for all its methods that share the epochs (the usual case: the same object is
then yielded for each, which :mod:`coopproc.report.rpe` uses to cut the segments once).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray, gap_limit_s
from coopproc.report.methods import method_order, position_methods_of
from coopproc.report.track_kernels import run_starts

__all__ = [
    "REFERENCE_METHOD",
    "Track",
    "codes_of",
    "float_column",
    "groups_of",
    "matched_tracks",
    "time_order",
]

REFERENCE_METHOD = "reference"
_AXES = ("east", "north", "up")
#: More runs of equal (platform, method) than this: the rows are not grouped.
_MAX_RUNS = 100_000
#: Rows of one group: a slice of the table, or row numbers in the group's order.
_Rows = slice | NDArray[np.intp]


class Track(NamedTuple):
    """One platform's method at its evaluation epochs: ``time`` (n,), ``est`` and ``ref``
    (n, 3) ENU positions, in time order (unpacks as ``platform, method, time, est, ref``)."""

    platform: str
    method: str
    time: FloatArray
    est: FloatArray
    ref: FloatArray


def float_column(frame: pd.DataFrame, name: str) -> FloatArray:
    """A column as float64 (a view of a float64 column: no copy of 40 M rows)."""
    column = frame[name]
    if column.dtype == np.float64:
        return np.asarray(column.to_numpy())
    return np.asarray(column.to_numpy(dtype=np.float64, na_value=np.nan))


def codes_of(column: pd.Series) -> tuple[NDArray[np.integer], list[str]]:
    """Integer codes (-1: missing) and the names they stand for, in the order pandas'
    ``groupby(sort=True)`` lists the groups (a categorical's category order, else sorted)."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        codes = column.array.codes  # type: ignore[attr-defined]  # a view, not a copy
        return np.asarray(codes), [str(c) for c in column.cat.categories]
    codes, uniques = pd.factorize(column, sort=True)
    return codes, [str(u) for u in uniques]


def groups_of(
    platform: NDArray[np.integer], method: NDArray[np.integer]
) -> list[tuple[int, int, _Rows]]:
    """``(platform code, method code, rows)`` of each group, by platform code; rows with a
    missing platform or method are left out."""
    n = platform.size
    if not n:
        return []
    starts = run_starts(platform, method)
    ends = np.append(starts[1:], n)
    pairs = (
        list(zip(platform[starts].tolist(), method[starts].tolist(), strict=True))
        if starts.size <= _MAX_RUNS
        else []
    )
    if pairs and len(set(pairs)) == len(pairs):  # each group one run of rows
        runs = zip(pairs, starts.tolist(), ends.tolist(), strict=True)
        return [(p, m, slice(s, e)) for (p, m), s, e in runs if p >= 0 and m >= 0]
    # rows not grouped: one stable sort by (platform, method) keeps each group's row order
    width = int(method.max()) + 2
    key = (platform.astype(np.int64) + 1) * width + (method.astype(np.int64) + 1)
    order = np.argsort(key, kind="stable")
    key = key[order]
    cuts = np.flatnonzero(key[1:] != key[:-1]) + 1
    out: list[tuple[int, int, _Rows]] = []
    for s, e in zip(
        np.concatenate([[0], cuts]).tolist(), np.concatenate([cuts, [n]]).tolist(), strict=True
    ):
        p, m = divmod(int(key[s]), width)
        if p >= 1 and m >= 1:
            out.append((p - 1, m - 1, order[s:e]))
    return out


def time_order(t: FloatArray) -> NDArray[np.intp] | None:
    """The stable time order of ``t`` (NaN last), None when it is in order already."""
    if t.size < 2 or bool(np.all(t[1:] >= t[:-1])):
        return None
    return np.argsort(t, kind="stable")


def _reference_at(t_ref: FloatArray, q: Sequence[FloatArray], t: FloatArray) -> FloatArray:
    """(n, 3) reference positions (rows sorted by time) at times ``t``; NaN outside them
    or in a gap (:func:`coopproc.model.gap_limit_s`)."""
    out = np.full((t.size, 3), np.nan)
    if not t_ref.size:
        return out
    for k in range(3):
        out[:, k] = np.interp(t, t_ref, q[k], left=np.nan, right=np.nan)
    right = np.searchsorted(t_ref, t)
    exact = t_ref[np.minimum(right, t_ref.size - 1)] == t
    if t_ref.size >= 2:
        steps = np.diff(t_ref)
        idx = np.clip(right, 1, t_ref.size - 1)
        out[(steps[idx - 1] > gap_limit_s(t_ref)) & ~exact] = np.nan
    return out


def _finite_rows(xyz: FloatArray) -> NDArray[np.bool_]:
    return np.isfinite(xyz[:, 0]) & np.isfinite(xyz[:, 1]) & np.isfinite(xyz[:, 2])


def matched_tracks(
    positions: pd.DataFrame, methods: Sequence[str] | None = None
) -> Iterator[Track]:
    """Each platform's methods at their evaluation epochs (module doc): platforms in
    ``groupby`` order, methods ``nav``, then ``methods`` (default: those of the table),
    then any other alphabetically; ``reference`` is never a method. A platform without
    reference rows yields its methods with no epochs (``n`` 0 in ``evaluation.csv``)."""
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    if not len(positions):
        return
    platform_codes, platforms = codes_of(positions["platform"])
    method_codes, names = codes_of(positions["method"])
    columns = {name: float_column(positions, name) for name in ("time", *_AXES, "error_h")}
    by_platform: dict[int, dict[str, _Rows]] = {}
    for p, m, rows in groups_of(platform_codes, method_codes):
        by_platform.setdefault(p, {})[names[m]] = rows
    for p in sorted(by_platform):
        yield from _platform_tracks(platforms[p], by_platform[p], columns, order)


def _platform_tracks(
    platform: str,
    groups: dict[str, _Rows],
    columns: dict[str, FloatArray],
    order: Sequence[str],
) -> Iterator[Track]:
    ref_rows = groups.get(REFERENCE_METHOD)
    t_ref = columns["time"][ref_rows] if ref_rows is not None else np.empty(0)
    sort = time_order(t_ref)
    q = [columns[a][ref_rows] if ref_rows is not None else np.empty(0) for a in _AXES]
    if sort is not None:
        t_ref, q = t_ref[sort], [v[sort] for v in q]
    at: tuple[FloatArray, FloatArray, NDArray[np.bool_]] | None = None  # truth at t
    kept: tuple[NDArray[np.bool_], FloatArray, FloatArray] | None = None  # its kept rows
    present = sorted(name for name in groups if name != REFERENCE_METHOD)
    for method in method_order(present, order):
        rows = groups[method]
        sort = time_order(columns["time"][rows])
        picked = [columns[a][rows] for a in ("time", *_AXES, "error_h")]
        if sort is not None:
            picked = [v[sort] for v in picked]
        t = picked[0]
        if at is None or not np.array_equal(at[0], t):  # else: the same epochs again
            truth = _reference_at(t_ref, q, t)
            at, kept = (t, truth, _finite_rows(truth)), None
        keep = at[2] & np.isfinite(picked[4])
        for v in picked[1:4]:
            keep &= np.isfinite(v)
        if kept is None or not np.array_equal(kept[0], keep):
            every = bool(np.all(keep))  # no copies: t and the reference as they are
            kept = (keep, t if every else t[keep], at[1] if every else at[1][keep])
        est = np.column_stack(picked[1:4] if kept[1] is t else [v[keep] for v in picked[1:4]])
        # the same time and reference objects for methods at the same epochs
        yield Track(platform, method, kept[1], est, kept[2])
