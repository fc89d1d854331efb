"""The mechanization of :mod:`coopproc.ins.mechanize` written plainly in numpy/Python.

Not used by the pipeline: it is the known answer the compiled loop is tested against,
and the baseline of the benchmark ratio (issue 12 item 7). It shares no code with the
compiled kernels (only the WGS-84 constants), so a slip in one shows as a difference.
"""

from __future__ import annotations

import numpy as np

from coopproc.frames import EARTH_RATE_RADPS, WGS84_A, WGS84_E2, WGS84_F, WGS84_GM
from coopproc.model import FloatArray

__all__ = ["mechanize_reference", "normal_gravity_reference"]


def _radii(lat: float) -> tuple[float, float]:
    w2 = 1.0 - WGS84_E2 * np.sin(lat) ** 2
    return WGS84_A * (1.0 - WGS84_E2) / w2**1.5, WGS84_A / np.sqrt(w2)


def normal_gravity_reference(lat: float, h: float) -> float:
    """Somigliana with the height correction (TR8350.2 eq. (4-1), (4-3)), plainly."""
    b = WGS84_A * (1.0 - WGS84_F)
    g_e, g_p = 9.7803253359, 9.8321849378
    s2 = np.sin(lat) ** 2
    g0 = (WGS84_A * g_e * np.cos(lat) ** 2 + b * g_p * s2) / np.sqrt(
        WGS84_A**2 * np.cos(lat) ** 2 + b**2 * s2
    )
    m = EARTH_RATE_RADPS**2 * WGS84_A**2 * b / WGS84_GM
    corr = 1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + m - 2.0 * WGS84_F * s2) * h
    return float(g0 * (corr + 3.0 * h**2 / WGS84_A**2))


def _quat(r: FloatArray) -> FloatArray:
    a = float(np.linalg.norm(r))
    if a == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate(([np.cos(a / 2)], np.sin(a / 2) * r / a))


def _qmul(p: FloatArray, q: FloatArray) -> FloatArray:
    w = p[0] * q[0] - p[1:] @ q[1:]
    return np.concatenate(([w], p[0] * q[1:] + q[0] * p[1:] + np.cross(p[1:], q[1:])))


def _dcm(q: FloatArray) -> FloatArray:
    w, v = q[0], q[1:]
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + 2.0 * w * vx + 2.0 * vx @ vx


def _step(
    nav: FloatArray, dth_p: FloatArray, dv_p: FloatArray, dth: FloatArray, dv: FloatArray, dt: float
) -> FloatArray:
    lat, lon, h = nav[0:3]
    v, q = nav[3:6], nav[6:10]
    m, n = _radii(lat)
    w_ie = EARTH_RATE_RADPS * np.array([0.0, np.cos(lat), np.sin(lat)])
    w_en = np.array([-v[1] / (m + h), v[0] / (n + h), v[0] * np.tan(lat) / (n + h)])
    zeta = (w_ie + w_en) * dt
    dvf = dv + np.cross(dth, dv) / 2 + (np.cross(dth_p, dv) + np.cross(dv_p, dth)) / 12
    dvf = dvf + np.cross(dth, np.cross(dth, dv)) / 6
    dvn = _dcm(q) @ dvf
    g = np.array([0.0, 0.0, -normal_gravity_reference(lat, h)])
    v_new = v + dvn - np.cross(zeta, dvn) / 2 + (g - np.cross(2 * w_ie + w_en, v)) * dt
    h_new = h + (v[2] + v_new[2]) / 2 * dt
    h_mid = (h + h_new) / 2
    lat_new = lat + (v[1] + v_new[1]) / 2 * dt / (m + h_mid)
    lat_mid = (lat + lat_new) / 2
    n_mid = _radii(lat_mid)[1]
    lon_new = lon + (v[0] + v_new[0]) / 2 * dt / ((n_mid + h_mid) * np.cos(lat_mid))
    q_new = _qmul(_qmul(_quat(-zeta), q), _quat(dth + np.cross(dth_p, dth) / 12))
    q_new = q_new / np.linalg.norm(q_new)
    return np.concatenate(([lat_new, lon_new, h_new], v_new, q_new))


def mechanize_reference(
    time_s: FloatArray, nav0: FloatArray, dtheta: FloatArray, dvel: FloatArray
) -> FloatArray:
    """(K, 10) nav per epoch, as :func:`coopproc.ins.mechanize.mechanize` computes it."""
    out = np.empty((len(time_s), 10))
    out[0] = nav0
    for k in range(1, len(time_s)):
        dt = float(time_s[k] - time_s[k - 1])
        out[k] = _step(out[k - 1], dtheta[k - 1], dvel[k - 1], dtheta[k], dvel[k], dt)
    return out
