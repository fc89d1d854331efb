"""Process models written once (issue 34 part 1): the white-acceleration constant-velocity
model the anchors' filters (paper 003 sec. 2.8), the tightly coupled GNSS filters and the
receiver clock share.

The dead-reckoning increment with heading, heading-rate and scale states is
:mod:`coopproc.estimation.dr_model` (the cooperative fusion's process model), and the INS
error state the INS engine's (:mod:`coopproc.ins.propagation`).
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = ["cv_transition"]


@numba.njit(cache=True)
def cv_transition(dt: float, psd: FloatArray) -> tuple[FloatArray, FloatArray]:
    """F and Q of X = [p (d); v (d)] over ``dt`` with white acceleration of PSD ``psd``
    (d,) per axis: F = [[I, dt I], [0, I]], Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]].

    A receiver clock [bias; drift] is the same model with d = 1 (``psd`` the drift's
    noise) and the bias's own white noise added to Q[0, 0]."""
    d = psd.shape[0]
    n = 2 * d
    f = np.eye(n)
    qm = np.zeros((n, n))
    for i in range(d):
        q = psd[i]
        f[i, d + i] = dt
        qm[i, i] = q * dt**3 / 3.0
        qm[i, d + i] = q * dt**2 / 2.0
        qm[d + i, i] = q * dt**2 / 2.0
        qm[d + i, d + i] = q * dt
    return f, qm
