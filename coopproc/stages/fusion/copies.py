"""Array copies for the fusion kernels, as plain loops (issue 32: the first run's compile).

``dst[:] = src`` or ``cp_x[k] = x`` between arrays inside a numba kernel is lowered with
a shape check whose failure message numba formats in compiled code: the first kernel of
a process that assigns an array to a slice compiles numba's string machinery (str, join,
repr of int tuples) with it. Measured on ``coopproc run sample_logs`` with an empty
NUMBA_CACHE_DIR: 9 such assignments in ``ekf_forward`` and ``rerun_block`` cost 7-9 s of
CPU of the 59 s the run spent compiling (2-core machine, load 6-7). The loops below are
the same element copies (bit for bit) without that check: the callers' shapes agree by
construction (a checkpoint row and the state, two (P, dim) navigation buffers).
"""

from __future__ import annotations

import numba

from coopproc.model import FloatArray

__all__ = ["copy1", "copy2"]


@numba.njit(cache=True, nogil=True)
def copy1(dst: FloatArray, src: FloatArray) -> None:  # pragma: no cover - compiled
    """``dst[:] = src`` for 1-D arrays of one length."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@numba.njit(cache=True, nogil=True)
def copy2(dst: FloatArray, src: FloatArray) -> None:  # pragma: no cover - compiled
    """``dst[:, :] = src`` for 2-D arrays of one shape."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]
