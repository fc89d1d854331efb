"""A digest of the ranges a fusion takes, whatever order and direction its table lists them in.

A processed range set that changed no range (RN-Based with nothing flagged on a clean
session; DI passing every pair through when the dead reckoning is too poor to smooth, as
at a simulated day of 10 platforms) holds the observed set's ranges, listed pair by pair
instead of in time order and with the sigma each row had. Its fusion is the observed
fusion: the self-calibration computes the same per-pair sigmas, and the floor the
processed fusions take (the observed fusion's sigmas) is what it computes anyway. At a day
each such fusion is about 40 s and 2.4 GB of working memory (issue 11), so
:func:`~coopproc.stages.fusion.entry.fusion_stage` compares digests and reuses the observed
solution.

The digest is of the multiset of the rows a fusion keeps (finite time and range): each
row's unordered platform pair, time, range and effective sigma (its own, else the
default) hashed to 128 bits by two independent splitmix64 mixes and summed modulo 2^64
(order-free: no sort of a day's 3.8 M rows, about 20 ms), with the number of rows of the
table. Two tables with the same digest hold the same ranges (two different multisets
collide with probability about 2^-128); two that list the same ranges with different
rows (a NaN range kept in one, dropped in the other) differ, and are fused each on its
own.
"""

from __future__ import annotations

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.model import FloatArray, Session
from coopproc.stages.shared.data import platform_codes, row_sigmas

__all__ = ["range_rows_digest"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


@numba.njit(cache=True)
def _mix(z: np.uint64) -> np.uint64:
    """splitmix64's finalizer (Steele, Lea and Flood 2014): a bijection of 64 bits."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@numba.njit(cache=True)
def _multiset_sums(
    pair: NDArray[np.int64],
    time_bits: NDArray[np.uint64],
    value_bits: NDArray[np.uint64],
    sigma_bits: NDArray[np.uint64],
    keep: NDArray[np.bool_],
) -> tuple[np.uint64, np.uint64, int]:
    """Two order-free 64-bit sums of the kept rows' hashes and the count of kept rows."""
    first = np.uint64(0)
    second = np.uint64(0)
    count = 0
    for i in range(pair.shape[0]):
        if not keep[i]:
            continue
        h1 = _mix(np.uint64(pair[i]) + _GOLDEN)
        h2 = _mix(np.uint64(pair[i]) ^ np.uint64(0xD6E8FEB86659FD93))
        for bits in (time_bits[i], value_bits[i], sigma_bits[i]):
            h1 = _mix(h1 ^ bits)
            h2 = _mix(h2 + bits + _GOLDEN)
        first += h1
        second += h2
        count += 1
    return first, second, count


def range_rows_digest(session: Session, ranges: pd.DataFrame, default_sigma_m: float) -> str:
    """The digest (module docstring) of ``ranges`` (columns time, from, to, range[, sigma])
    as a fusion of ``session`` reads it, rows without a sigma taking ``default_sigma_m``."""
    time = pd.to_numeric(ranges["time"], errors="coerce").to_numpy(np.float64)
    value = pd.to_numeric(ranges["range"], errors="coerce").to_numpy(np.float64)
    sigma = row_sigmas(ranges, default_sigma_m)
    ids = sorted(session.platforms)
    first = platform_codes(ranges["from"], ids)
    second = platform_codes(ranges["to"], ids)
    width = len(ids) + 1  # an unknown id (-1) is a code of its own
    pair = (np.minimum(first, second) + 1) * width + np.maximum(first, second) + 1
    keep = np.isfinite(time) & np.isfinite(value)
    sums = _multiset_sums(pair, _bits(time), _bits(value), _bits(sigma), keep)
    return f"{int(sums[0]):016x}{int(sums[1]):016x}-{int(sums[2])}-{len(ranges)}"


def _bits(values: FloatArray) -> NDArray[np.uint64]:
    """The float64s' bit patterns (0.0 and -0.0 alike: equal ranges are the same range)."""
    out = np.ascontiguousarray(values, dtype=np.float64) + 0.0  # -0.0 + 0.0 = +0.0
    return out.view(np.uint64)
