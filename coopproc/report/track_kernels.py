"""Compiled loops of the evaluation and RPE statistics, bit for bit numpy's results.

Each loop replaces numpy expressions over (n, 3) arrays that made several temporaries
and reduced along the short axis (slow at 40 M rows). They do the same floating-point
operations in the same order, so ``evaluation.csv`` and ``rpe.csv`` keep their bytes:

- ``np.sum(a, axis=1)`` of an (n, 3) array adds ``(a0 + a1) + a2``;
- ``np.sum(a, axis=0)`` (and ``mean``, ``std``) of a C-ordered (n, 3) array adds the rows
  one after the other to 0.0 (no pairwise summation across rows);
- ``np.cumsum`` adds sequentially; ``min`` and ``max`` keep the later of two equal values
  (the sign of a zero); ``np.hypot`` and ``searchsorted`` do not depend on an order.

Sums over a contiguous 1-D array (numpy's pairwise summation) and medians stay numpy's
(:mod:`coopproc.report.evaluation`, :mod:`coopproc.report.rpe`). No fast-math: the
compiler may not reorder or fuse these operations.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = ["error_norms", "path_length", "segment_ends", "segment_errors"]


@numba.njit(cache=True, nogil=True)
def error_norms(
    moved: FloatArray, ref: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """For ``d = moved - ref`` ((n, 3), n >= 1): the 3-D norms ``sqrt(sum(d * d, axis=1))``,
    the horizontal ``hypot(d_e, d_n)``, and a (6, 3) array of per-axis ``rms``, ``mean``,
    ``std`` (population), ``min``, ``max``, ``max |d|`` as numpy's axis-0 reductions."""
    n = moved.shape[0]
    e3 = np.empty(n)
    h = np.empty(n)
    # sums from 0.0, minima and maxima from the first row, ties to the later value: numpy's
    # reductions (np.minimum(a, b) is ``a if a < b else b``), down to the sign of a zero
    s0, s1, s2 = 0.0, 0.0, 0.0
    q0, q1, q2 = 0.0, 0.0, 0.0
    lo0, lo1, lo2 = moved[0, 0] - ref[0, 0], moved[0, 1] - ref[0, 1], moved[0, 2] - ref[0, 2]
    hi0, hi1, hi2 = lo0, lo1, lo2
    ab0, ab1, ab2 = abs(lo0), abs(lo1), abs(lo2)
    for i in range(n):
        d0 = moved[i, 0] - ref[i, 0]
        d1 = moved[i, 1] - ref[i, 1]
        d2 = moved[i, 2] - ref[i, 2]
        e3[i] = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        h[i] = np.hypot(d0, d1)
        s0 += d0
        s1 += d1
        s2 += d2
        q0 += d0 * d0
        q1 += d1 * d1
        q2 += d2 * d2
        if i:
            lo0 = lo0 if lo0 < d0 else d0
            lo1 = lo1 if lo1 < d1 else d1
            lo2 = lo2 if lo2 < d2 else d2
            hi0 = hi0 if hi0 > d0 else d0
            hi1 = hi1 if hi1 > d1 else d1
            hi2 = hi2 if hi2 > d2 else d2
            ab0 = max(ab0, abs(d0))
            ab1 = max(ab1, abs(d1))
            ab2 = max(ab2, abs(d2))
    m0, m1, m2 = s0 / n, s1 / n, s2 / n
    v0, v1, v2 = 0.0, 0.0, 0.0
    for i in range(n):
        c0 = (moved[i, 0] - ref[i, 0]) - m0
        c1 = (moved[i, 1] - ref[i, 1]) - m1
        c2 = (moved[i, 2] - ref[i, 2]) - m2
        v0 += c0 * c0
        v1 += c1 * c1
        v2 += c2 * c2
    stats = np.empty((6, 3))
    stats[0, 0], stats[0, 1], stats[0, 2] = np.sqrt(q0 / n), np.sqrt(q1 / n), np.sqrt(q2 / n)
    stats[1, 0], stats[1, 1], stats[1, 2] = m0, m1, m2
    stats[2, 0], stats[2, 1], stats[2, 2] = np.sqrt(v0 / n), np.sqrt(v1 / n), np.sqrt(v2 / n)
    stats[3, 0], stats[3, 1], stats[3, 2] = lo0, lo1, lo2
    stats[4, 0], stats[4, 1], stats[4, 2] = hi0, hi1, hi2
    stats[5, 0], stats[5, 1], stats[5, 2] = ab0, ab1, ab2
    return e3, h, stats


@numba.njit(cache=True, nogil=True)
def path_length(q: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    """Travelled distance along the (n, 3) points: ``[0, cumsum(|q[k] - q[k - 1]|)]``."""
    n = q.shape[0]
    s = np.empty(n)
    if n:
        s[0] = 0.0
    for k in range(1, n):
        dx = q[k, 0] - q[k - 1, 0]
        dy = q[k, 1] - q[k - 1, 1]
        dz = q[k, 2] - q[k - 1, 2]
        step = np.sqrt((dx * dx + dy * dy) + dz * dz)
        s[k] = step if k == 1 else s[k - 1] + step
    return s


@numba.njit(cache=True, nogil=True)
def segment_ends(s: FloatArray, length_m: float) -> np.ndarray:  # pragma: no cover
    """``searchsorted(s, s + length_m, "left")`` for a non-decreasing ``s``, cut where it
    reaches ``s.size`` (those starts have no segment): the ends of starts 0, 1, ..."""
    n = s.size
    ends = np.empty(n, dtype=np.int64)
    j = 0
    m = 0
    for i in range(n):
        target = s[i] + length_m
        while j < n and s[j] < target:
            j += 1
        if j >= n:
            break
        ends[i] = j
        m = i + 1
    return ends[:m]


@numba.njit(cache=True, nogil=True)
def segment_errors(
    p: FloatArray, q: FloatArray, ends: np.ndarray
) -> FloatArray:  # pragma: no cover
    """``|(p[j] - p[i]) - (q[j] - q[i])|`` for start i = 0, 1, ... and its end j."""
    out = np.empty(ends.size)
    for i in range(ends.size):
        j = ends[i]
        m0 = (p[j, 0] - p[i, 0]) - (q[j, 0] - q[i, 0])
        m1 = (p[j, 1] - p[i, 1]) - (q[j, 1] - q[i, 1])
        m2 = (p[j, 2] - p[i, 2]) - (q[j, 2] - q[i, 2])
        out[i] = np.sqrt((m0 * m0 + m1 * m1) + m2 * m2)
    return out


@numba.njit(cache=True, nogil=True)
def run_starts(first: np.ndarray, second: np.ndarray) -> np.ndarray:  # pragma: no cover
    """Row numbers where ``(first, second)`` changes (0 included, for n > 0): the starts of
    the runs of equal code pairs, without a temporary per row."""
    n = first.size
    count = 1 if n else 0
    for i in range(1, n):
        if first[i] != first[i - 1] or second[i] != second[i - 1]:
            count += 1
    out = np.empty(count, dtype=np.int64)
    k = 0
    for i in range(n):
        if i == 0 or first[i] != first[i - 1] or second[i] != second[i - 1]:
            out[k] = i
            k += 1
    return out
