"""WGS-84 earth model for the mechanization: curvature radii, normal gravity, earth and
transport rates in the local-level ENU frame (docs/methods-ins.md, "Earth model").

All functions are numba-compiled and callable from Python with floats; angles in rad.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.frames import EARTH_RATE_RADPS, WGS84_A, WGS84_E2, WGS84_F, WGS84_GM
from coopproc.model import FloatArray

__all__ = [
    "earth_rate_enu",
    "ecef_to_enu_matrix",
    "llh_to_ecef",
    "normal_gravity",
    "radii",
    "transport_rate_enu",
]

#: Somigliana: normal gravity at the equator (m/s^2) and its constant k = (b g_p)/(a g_e) - 1.
_GAMMA_E = 9.7803253359
_SOMIGLIANA_K = 0.00193185265241
#: m = omega^2 a^2 b / GM (WGS-84), used by the height correction.
_WGS84_B = WGS84_A * (1.0 - WGS84_F)
_M_RATIO = EARTH_RATE_RADPS**2 * WGS84_A**2 * _WGS84_B / WGS84_GM


@numba.njit(cache=True)
def radii(lat: float) -> tuple[float, float]:
    """Meridian (M) and prime-vertical (N) radii of curvature (m) at latitude ``lat``."""
    s2 = np.sin(lat) ** 2
    w = np.sqrt(1.0 - WGS84_E2 * s2)
    n = WGS84_A / w
    m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w)
    return m, n


@numba.njit(cache=True)
def normal_gravity(lat: float, h: float) -> float:
    """Magnitude of WGS-84 normal gravity (m/s^2) at ``lat`` (rad), height ``h`` (m).

    Somigliana's closed form on the ellipsoid, gamma_0 = gamma_e (1 + k sin^2 lat) /
    sqrt(1 - e^2 sin^2 lat), with the second-order height correction of NIMA TR8350.2
    eq. (4-3): gamma_h = gamma_0 [1 - 2/a (1 + f + m - 2 f sin^2 lat) h + 3 h^2 / a^2].
    Normal gravity includes the centrifugal acceleration; its direction is taken as the
    ellipsoid normal (deflection of the vertical neglected).
    """
    s2 = np.sin(lat) ** 2
    g0 = _GAMMA_E * (1.0 + _SOMIGLIANA_K * s2) / np.sqrt(1.0 - WGS84_E2 * s2)
    corr = 1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + _M_RATIO - 2.0 * WGS84_F * s2) * h
    return g0 * (corr + 3.0 * h * h / (WGS84_A * WGS84_A))


@numba.njit(cache=True)
def earth_rate_enu(lat: float) -> FloatArray:
    """omega_ie^n in ENU: (0, Omega cos lat, Omega sin lat), rad/s."""
    out = np.empty(3)
    out[0] = 0.0
    out[1] = EARTH_RATE_RADPS * np.cos(lat)
    out[2] = EARTH_RATE_RADPS * np.sin(lat)
    return out


@numba.njit(cache=True)
def transport_rate_enu(lat: float, h: float, v_enu: FloatArray) -> FloatArray:
    """omega_en^n in ENU: (-v_N/(M+h), v_E/(N+h), v_E tan(lat)/(N+h)), rad/s."""
    m, n = radii(lat)
    out = np.empty(3)
    out[0] = -v_enu[1] / (m + h)
    out[1] = v_enu[0] / (n + h)
    out[2] = v_enu[0] * np.tan(lat) / (n + h)
    return out


@numba.njit(cache=True)
def llh_to_ecef(lat: float, lon: float, h: float) -> FloatArray:
    """ECEF (m) of a geodetic position (rad, rad, m), WGS-84."""
    _, n = radii(lat)
    out = np.empty(3)
    out[0] = (n + h) * np.cos(lat) * np.cos(lon)
    out[1] = (n + h) * np.cos(lat) * np.sin(lon)
    out[2] = (n * (1.0 - WGS84_E2) + h) * np.sin(lat)
    return out


@numba.njit(cache=True)
def ecef_to_enu_matrix(lat: float, lon: float) -> FloatArray:
    """C_e^n: rotates ECEF vectors into the ENU frame at (lat, lon)."""
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    c = np.empty((3, 3))
    c[0, 0], c[0, 1], c[0, 2] = -so, co, 0.0
    c[1, 0], c[1, 1], c[1, 2] = -sl * co, -sl * so, cl
    c[2, 0], c[2, 1], c[2, 2] = cl * co, cl * so, sl
    return c
