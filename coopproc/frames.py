"""Geodetic / ECEF <-> local ENU conversions on the WGS-84 ellipsoid (pymap3d wrappers).

Names are ``<from>2<to>`` as in pymap3d; arrays are (n, 3) with columns in the order of
the names (lat deg, lon deg, height m; x, y, z m; east, north, up m); the origin is
``(lat deg, lon deg, height m)``.
"""

from __future__ import annotations

import numpy as np
import pymap3d
from numpy.typing import ArrayLike

from coopproc.model import FloatArray

__all__ = [
    "EARTH_RATE_RADPS",
    "WGS84_A",
    "WGS84_E2",
    "WGS84_F",
    "WGS84_GM",
    "ecef2enu",
    "ecef2geodetic",
    "ecef_cov2enu_sigma",
    "enu2ecef",
    "enu2geodetic",
    "geodetic2ecef",
    "geodetic2enu",
]

#: The WGS-84 ellipsoid, defined once for every module (the numba kernels read them as
#: module floats): semi-major axis (m), flattening, first eccentricity squared, GM
#: (m^3/s^2) and earth rotation rate (rad/s); NIMA TR8350.2 table 3.1. The same a and f
#: as ``pymap3d.Ellipsoid.from_name("wgs84")``, which the conversions below use
#: (tests/io/test_timeconv_frames.py checks them against it).
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
WGS84_GM = 3.986004418e14
EARTH_RATE_RADPS = 7.2921151467e-5

Origin = tuple[float, float, float]


def _cols(points: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return p[:, 0], p[:, 1], p[:, 2]


def _stack(a: object, b: object, c: object) -> FloatArray:
    return np.column_stack(
        [np.asarray(a, np.float64), np.asarray(b, np.float64), np.asarray(c, np.float64)]
    ).reshape(-1, 3)


def geodetic2enu(llh: ArrayLike, origin: Origin) -> FloatArray:
    """ENU (m) at ``origin`` of points given as lat (deg), lon (deg), height (m)."""
    lat, lon, h = _cols(llh)
    return _stack(*pymap3d.geodetic2enu(lat, lon, h, *origin))


def enu2geodetic(enu: ArrayLike, origin: Origin) -> FloatArray:
    """lat (deg), lon (deg), height (m) of ENU points (m) at ``origin``."""
    e, n, u = _cols(enu)
    return _stack(*pymap3d.enu2geodetic(e, n, u, *origin))


def ecef2enu(xyz: ArrayLike, origin: Origin) -> FloatArray:
    """ENU (m) at ``origin`` of ECEF points (m)."""
    x, y, z = _cols(xyz)
    return _stack(*pymap3d.ecef2enu(x, y, z, *origin))


def enu2ecef(enu: ArrayLike, origin: Origin) -> FloatArray:
    """ECEF (m) of ENU points (m) at ``origin``."""
    e, n, u = _cols(enu)
    return _stack(*pymap3d.enu2ecef(e, n, u, *origin))


def geodetic2ecef(llh: ArrayLike) -> FloatArray:
    """ECEF (m) of lat (deg), lon (deg), height (m)."""
    lat, lon, h = _cols(llh)
    return _stack(*pymap3d.geodetic2ecef(lat, lon, h))


def ecef2geodetic(xyz: ArrayLike) -> FloatArray:
    """lat (deg), lon (deg), height (m) of ECEF points (m)."""
    x, y, z = _cols(xyz)
    return _stack(*pymap3d.ecef2geodetic(x, y, z))


def ecef_cov2enu_sigma(cov_ecef: ArrayLike, origin: Origin) -> FloatArray:
    """1-sigma east, north, up (m) of (n, 3, 3) ECEF covariances, rotated at ``origin``.

    C_enu = R C_ecef R^T with R the ECEF->ENU rotation at the origin's lat/lon.
    """
    lat = np.radians(origin[0])
    lon = np.radians(origin[1])
    sl, cl, sp, cp = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    rot = np.array(
        [
            [-sp, cp, 0.0],
            [-sl * cp, -sl * sp, cl],
            [cl * cp, cl * sp, sl],
        ]
    )
    cov = np.asarray(cov_ecef, dtype=np.float64).reshape(-1, 3, 3)
    cov_enu = np.einsum("ij,njk,lk->nil", rot, cov, rot)
    return np.sqrt(np.clip(np.diagonal(cov_enu, axis1=1, axis2=2), 0.0, None))
