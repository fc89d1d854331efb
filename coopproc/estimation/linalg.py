"""Compiled small dense linear algebra for the per-epoch filter and smoother loops."""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = ["cholesky_solve_nb"]


@numba.njit(cache=True)
def cholesky_solve_nb(a: FloatArray, b: FloatArray) -> FloatArray:
    """X with A X = B for symmetric positive definite A (n, n) and B (n, m), compiled."""
    n = a.shape[0]
    low = np.zeros((n, n))
    for j in range(n):
        acc = a[j, j]
        for k in range(j):
            acc -= low[j, k] * low[j, k]
        low[j, j] = np.sqrt(max(acc, 1e-300))
        for i in range(j + 1, n):
            acc = a[i, j]
            for k in range(j):
                acc -= low[i, k] * low[j, k]
            low[i, j] = acc / low[j, j]
    m = b.shape[1]
    x = np.empty((n, m))
    for col in range(m):
        y = np.empty(n)
        for i in range(n):
            acc = b[i, col]
            for k in range(i):
                acc -= low[i, k] * y[k]
            y[i] = acc / low[i, i]
        for i in range(n - 1, -1, -1):
            acc = y[i]
            for k in range(i + 1, n):
                acc -= low[k, i] * x[k, col]
            x[i, col] = acc / low[i, i]
    return x
