"""The fusion kernels' navigation: each platform's own samples interpolated at an epoch.

The filter and the smoother (:mod:`coopproc.stages.fusion.ekf`,
:mod:`coopproc.stages.fusion.smoother`) form each dead-reckoning increment from the
navigation at two successive epochs; they interpolate it here as they reach each epoch
instead of holding the navigation at every range epoch (P x K x dim floats, about 0.6 GB
for a day of 10 platforms; issue 11).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = ["nav_at"]


@numba.njit(cache=True)
def nav_at(
    nav_t: FloatArray,
    nav_v: FloatArray,
    nav_ptr: NDArray[np.int64],
    x: float,
    cursor: NDArray[np.int64],
    out: FloatArray,
) -> None:
    """Each platform's navigation at time ``x`` into ``out`` (P, dim), in place.

    Platform p's samples are ``nav_t[nav_ptr[p]:nav_ptr[p + 1]]`` (ascending) and the same
    rows of ``nav_v`` (east/north[/up]); the value is ``np.interp``'s, bit for bit (its
    formula, its end values, its NaN fallback). ``cursor[p]``: the last sample at or before
    the previous time (start with -1), advanced as times grow, searched again when a time
    goes back (the smoother's blocks).
    """
    for p in range(nav_ptr.shape[0] - 1):
        lo = nav_ptr[p]
        hi = nav_ptr[p + 1]
        j = cursor[p]
        if j < lo - 1 or j >= hi or (j >= lo and nav_t[j] > x):
            j = lo - 1 + np.searchsorted(nav_t[lo:hi], x, side="right")
        while j + 1 < hi and nav_t[j + 1] <= x:
            j += 1
        cursor[p] = j
        for ax in range(out.shape[1]):
            if j < lo:
                out[p, ax] = nav_v[lo, ax]
            elif j == hi - 1 or nav_t[j] == x:
                out[p, ax] = nav_v[j, ax]
            else:
                slope = (nav_v[j + 1, ax] - nav_v[j, ax]) / (nav_t[j + 1] - nav_t[j])
                value = slope * (x - nav_t[j]) + nav_v[j, ax]
                if np.isnan(value):  # numpy's fallback: from the other end
                    value = slope * (x - nav_t[j + 1]) + nav_v[j + 1, ax]
                    if np.isnan(value) and nav_v[j, ax] == nav_v[j + 1, ax]:
                        value = nav_v[j, ax]
                out[p, ax] = value
