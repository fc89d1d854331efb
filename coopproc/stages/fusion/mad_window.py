"""The forward filter's windowed eq. (20) median, kept sorted instead of sorted per epoch.

With staggered polling an epoch holds one range (and a leader's fix), fewer than
:data:`~coopproc.stages.fusion.ekf.MAD_EPOCH_MIN` observations, so its MAD unit-weight
sigma is the median of its standardized innovations together with the last ``mad_window``
ones (:func:`~coopproc.stages.fusion.ekf.ekf_forward`). Taking that median by a partition
of the pooled values at every epoch was about three quarters of the forward pass's time
(10 x 1 h: 0.55 s of 0.75 s). Here the window is also kept as a sorted array (one
insertion and one removal per innovation, a few dozen moves) and the median is read off
the merge of that array with the epoch's few sorted values: the same two order
statistics, the same ``(a + b) / 2`` as ``np.median`` (numba's), so the same float.
A NaN has no order: while the window or the epoch holds one, the caller pools and
partitions as before (``nan_count``).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = ["sorted_insert", "sorted_remove", "union_median", "window_push"]


@numba.njit(cache=True)
def sorted_insert(srt: FloatArray, n: int, value: float) -> None:
    """Insert ``value`` (not NaN) into ascending ``srt[:n]`` (room for n + 1)."""
    i = np.searchsorted(srt[:n], value)
    for k in range(n, i, -1):
        srt[k] = srt[k - 1]
    srt[i] = value


@numba.njit(cache=True)
def sorted_remove(srt: FloatArray, n: int, value: float) -> None:
    """Remove one ``value`` (present, not NaN) from ascending ``srt[:n]``."""
    i = np.searchsorted(srt[:n], value)
    for k in range(i, n - 1):
        srt[k] = srt[k + 1]


@numba.njit(cache=True)
def window_push(ring: FloatArray, srt: FloatArray, state: NDArray[np.int64], value: float) -> None:
    """Add ``value`` to the window ``ring`` (its length is the window), the oldest value
    leaving a full one; ``srt`` keeps the window's values but NaN in ascending order.
    ``state``: values in the ring, next slot, values in ``srt``, NaN in the ring."""
    size = ring.shape[0]
    at = state[1]
    if state[0] == size:  # the oldest value leaves the window
        if np.isnan(ring[at]):
            state[3] -= 1
        else:
            sorted_remove(srt, state[2], ring[at])
            state[2] -= 1
    ring[at] = value
    if np.isnan(value):
        state[3] += 1
    else:
        sorted_insert(srt, state[2], value)
        state[2] += 1
    state[1] = (at + 1) % size
    state[0] = min(state[0] + 1, size)


@numba.njit(cache=True)
def _sort_small(e: FloatArray, m: int) -> None:
    """Insertion sort of ``e[:m]`` in place (a handful of values, none NaN)."""
    for i in range(1, m):
        value = e[i]
        k = i - 1
        while k >= 0 and e[k] > value:
            e[k + 1] = e[k]
            k -= 1
        e[k + 1] = value


@numba.njit(cache=True)
def union_median(srt: FloatArray, n: int, e: FloatArray, m: int) -> float:
    """``np.median`` of ``srt[:n]`` (ascending) and ``e[:m]`` (sorted here, in place)
    together, n + m >= 1, no NaN: the middle order statistic, or the mean ``(a + b) / 2``
    of the two middle ones as numba's ``np.median`` computes it."""
    _sort_small(e, m)
    total = n + m
    half = total >> 1
    i = 0
    j = 0
    prev = 0.0
    value = 0.0
    for _ in range(half + 1):  # walk the merge up to order statistic ``half``
        prev = value
        if j >= m or (i < n and srt[i] <= e[j]):
            value = srt[i]
            i += 1
        else:
            value = e[j]
            j += 1
    if total & 1 == 0:
        return (prev + value) / 2
    return value
