"""Angle conventions shared by the localization filters and their reporters.

Math angles are radians counter-clockwise from east; headings are degrees clockwise from
north (docs/locate.md).
"""

from __future__ import annotations

import numpy as np

from coopproc.model import FloatArray

__all__ = ["heading_deg", "wrap_deg", "wrap_pi"]


def wrap_pi(angle_rad: FloatArray | float) -> FloatArray:
    """Angles wrapped to [-pi, pi)."""
    return np.asarray((np.asarray(angle_rad) + np.pi) % (2.0 * np.pi) - np.pi)


def heading_deg(phi_rad: FloatArray | float) -> FloatArray:
    """Math angle (rad, CCW from east) -> heading (degrees clockwise from north, [0, 360))."""
    return np.asarray((90.0 - np.degrees(np.asarray(phi_rad))) % 360.0)


def wrap_deg(x: FloatArray | float) -> FloatArray:
    """Degrees wrapped to [-180, 180)."""
    return np.asarray((np.asarray(x) + 180.0) % 360.0 - 180.0)
