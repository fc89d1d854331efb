"""Sampled time series: the float array type and the one gap rule, below the data model.

Shared by :mod:`coopproc.model` (trajectories, sessions) and :mod:`coopproc.sensors` (raw
IMU and odometer samples), which the session holds: both import from here, so neither
imports the other's dependents (issue 34: no cycle between model and sensors).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["GAP_FACTOR", "FloatArray", "gap_limit_s"]

FloatArray = NDArray[np.float64]

#: A gap in a time series: an interval between consecutive epochs longer than this many
#: times the median interval (the one rule of :meth:`Trajectory.interpolate_within
#: <coopproc.model.Trajectory.interpolate_within>`, the coverage checks and the figures).
GAP_FACTOR = 2.5


def gap_limit_s(time_s: FloatArray) -> float:
    """The longest interval between consecutive epochs of ``time_s`` that is not a gap, s.

    :data:`GAP_FACTOR` times the median interval; infinite with fewer than two epochs.
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.shape[0] < 2:
        return float("inf")
    return GAP_FACTOR * float(np.median(np.diff(t)))
