"""Quaternion and rotation helpers (numba-compiled): q = (w, x, y, z), Hamilton product,
``q`` rotates body vectors into the navigation frame (C_b^n).

Euler angles (REP 103, body x forward, y left, z up; ENU): C_b^n = Rz(yaw) Ry(pitch)
Rx(roll); yaw counter-clockwise from east (heading = 90 deg - yaw, clockwise from north);
positive pitch is nose down (a rotation about the left axis).
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = [
    "dcm_to_euler",
    "euler_to_quat",
    "qmul",
    "quat_to_dcm",
    "quat_to_euler",
    "rotvec_to_quat",
    "skew",
]


@numba.njit(cache=True)
def qmul(p: FloatArray, q: FloatArray) -> FloatArray:
    """Hamilton product p * q."""
    out = np.empty(4)
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    out[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    out[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    out[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    return out


@numba.njit(cache=True)
def rotvec_to_quat(r: FloatArray) -> FloatArray:
    """Quaternion of the rotation vector ``r`` (rad): (cos |r|/2, sin(|r|/2) r/|r|).

    For small angles the series of sin(x/2)/x keeps full precision.
    """
    a2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    out = np.empty(4)
    if a2 < 1e-8:
        out[0] = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = np.sqrt(a2)
        out[0] = np.cos(0.5 * a)
        s = np.sin(0.5 * a) / a
    out[1] = s * r[0]
    out[2] = s * r[1]
    out[3] = s * r[2]
    return out


@numba.njit(cache=True)
def quat_to_dcm(q: FloatArray) -> FloatArray:
    """C (3, 3) of the unit quaternion ``q`` (body -> navigation for an attitude)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    c = np.empty((3, 3))
    c[0, 0] = w * w + x * x - y * y - z * z
    c[0, 1] = 2.0 * (x * y - w * z)
    c[0, 2] = 2.0 * (x * z + w * y)
    c[1, 0] = 2.0 * (x * y + w * z)
    c[1, 1] = w * w - x * x + y * y - z * z
    c[1, 2] = 2.0 * (y * z - w * x)
    c[2, 0] = 2.0 * (x * z - w * y)
    c[2, 1] = 2.0 * (y * z + w * x)
    c[2, 2] = w * w - x * x - y * y + z * z
    return c


@numba.njit(cache=True)
def euler_to_quat(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Quaternion of C_b^n = Rz(yaw) Ry(pitch) Rx(roll), angles in rad."""
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    out = np.empty(4)
    out[0] = cy * cp * cr + sy * sp * sr
    out[1] = cy * cp * sr - sy * sp * cr
    out[2] = cy * sp * cr + sy * cp * sr
    out[3] = sy * cp * cr - cy * sp * sr
    return out


@numba.njit(cache=True)
def dcm_to_euler(c: FloatArray) -> FloatArray:
    """(roll, pitch, yaw) rad of C_b^n = Rz(yaw) Ry(pitch) Rx(roll)."""
    out = np.empty(3)
    out[0] = np.arctan2(c[2, 1], c[2, 2])
    out[1] = np.arcsin(max(-1.0, min(1.0, -c[2, 0])))
    out[2] = np.arctan2(c[1, 0], c[0, 0])
    return out


@numba.njit(cache=True)
def quat_to_euler(q: FloatArray) -> FloatArray:
    """(roll, pitch, yaw) rad of the attitude quaternion ``q``."""
    return dcm_to_euler(quat_to_dcm(q))


@numba.njit(cache=True)
def skew(v: FloatArray) -> FloatArray:
    """[v x], the cross-product matrix: skew(a) @ b == cross(a, b)."""
    s = np.zeros((3, 3))
    s[0, 1] = -v[2]
    s[0, 2] = v[1]
    s[1, 0] = v[2]
    s[1, 2] = -v[0]
    s[2, 0] = -v[1]
    s[2, 1] = v[0]
    return s
