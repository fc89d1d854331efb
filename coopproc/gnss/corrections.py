"""Propagation corrections and geometry of a pseudorange (vectorised over satellites).

- :func:`azel`: azimuth and elevation of satellites seen from a receiver (ECEF);
- :func:`klobuchar_s`: the GPS broadcast ionosphere model, IS-GPS-200 20.3.3.5.2.5
  (Klobuchar 1987), L1 delay in seconds;
- :func:`saastamoinen_m`: the Saastamoinen (1972) zenith delays with a standard
  atmosphere (pressure and temperature from height, 70 % relative humidity, as RTKLIB's
  ``tropmodel``), mapped by 1 / cos(z);
- :func:`code_variance_m2`: the elevation-dependent variance of a code pseudorange,
  a^2 + b^2 / sin^2(el) (RTKLIB manual E.6), plus the models' own error variances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.frames import WGS84_A, WGS84_E2
from coopproc.model import FloatArray

__all__ = [
    "CodeErrorModel",
    "azel",
    "code_variance_m2",
    "ecef_to_llh",
    "klobuchar_s",
    "saastamoinen_m",
]


def ecef_to_llh(xyz: FloatArray) -> tuple[float, float, float]:
    """Geodetic latitude, longitude (rad) and ellipsoidal height (m) of one ECEF point
    (WGS 84, iterative; the centre of the earth gives (0, 0, -a))."""
    x, y, z = (float(v) for v in xyz)
    p = np.hypot(x, y)
    if p < 1e-9 and abs(z) < 1e-9:
        return 0.0, 0.0, -WGS84_A
    lat = np.arctan2(z, p * (1.0 - WGS84_E2))
    h = 0.0
    for _ in range(10):
        n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n if abs(np.cos(lat)) > 1e-12 else abs(z) - n * (1 - WGS84_E2)
        new = np.arctan2(z, p * (1.0 - WGS84_E2 * n / (n + h)))
        if abs(new - lat) < 1e-13:
            lat = new
            break
        lat = new
    return float(lat), float(np.arctan2(y, x)), float(h)


def azel(
    receiver_ecef: FloatArray,
    sat_ecef: FloatArray,
    lat_lon_rad: tuple[float, float] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Azimuth (rad, from north, clockwise) and elevation (rad) of ``sat_ecef`` (n, 3)
    (``lat_lon_rad``: the receiver's, when the caller has them already)."""
    lat, lon = lat_lon_rad if lat_lon_rad is not None else ecef_to_llh(receiver_ecef)[:2]
    d = sat_ecef - receiver_ecef[None, :]
    sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
    east = -sl * d[:, 0] + cl * d[:, 1]
    north = -sp * cl * d[:, 0] - sp * sl * d[:, 1] + cp * d[:, 2]
    up = cp * cl * d[:, 0] + cp * sl * d[:, 1] + sp * d[:, 2]
    az = np.arctan2(east, north) % (2.0 * np.pi)
    el = np.arctan2(up, np.hypot(east, north))
    return az, el


def klobuchar_s(
    gpst_s: float,
    lat_rad: float,
    lon_rad: float,
    az: FloatArray,
    el: FloatArray,
    alpha: tuple[float, float, float, float],
    beta: tuple[float, float, float, float],
) -> FloatArray:
    """L1 ionospheric delay (s) of the broadcast model (IS-GPS-200 20.3.3.5.2.5).

    Angles of the standard in semicircles; ``gpst_s`` any GPST seconds (the local time
    uses it modulo one day).
    """
    e = el / np.pi
    phi_u, lam_u = lat_rad / np.pi, lon_rad / np.pi
    psi = 0.0137 / (e + 0.11) - 0.022
    phi_i = np.clip(phi_u + psi * np.cos(az), -0.416, 0.416)
    lam_i = lam_u + psi * np.sin(az) / np.cos(phi_i * np.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)
    t = (4.32e4 * lam_i + gpst_s) % 86400.0
    f = 1.0 + 16.0 * (0.53 - e) ** 3
    amp = alpha[0] + phi_m * (alpha[1] + phi_m * (alpha[2] + phi_m * alpha[3]))
    per = beta[0] + phi_m * (beta[1] + phi_m * (beta[2] + phi_m * beta[3]))
    amp = np.maximum(amp, 0.0)
    per = np.maximum(per, 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    day = 5e-9 + amp * (1.0 - x * x / 2.0 + x**4 / 24.0)
    return np.asarray(f * np.where(np.abs(x) < 1.57, day, 5e-9), dtype=np.float64)


def saastamoinen_m(
    lat_rad: float, height_m: float, el: FloatArray, humidity: float = 0.7
) -> FloatArray:
    """Slant tropospheric delay (m): Saastamoinen (1972) with a standard atmosphere.

    Pressure 1013.25 (1 - 2.2557e-5 h)^5.2568 hPa, temperature 15 - 6.5e-3 h deg C,
    water vapour from ``humidity``; zero outside -100 m .. 10 km or below the horizon.
    """
    el = np.asarray(el, dtype=np.float64)
    if height_m < -100.0 or height_m > 1e4:
        return np.zeros_like(el)
    h = max(height_m, 0.0)
    pressure = 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568
    temp = 15.0 - 6.5e-3 * h + 273.16
    vapour = 6.108 * humidity * np.exp((17.15 * temp - 4684.0) / (temp - 38.45))
    cos_z = np.cos(np.pi / 2.0 - np.maximum(el, 1e-3))
    dry = 0.0022768 * pressure / (1.0 - 0.00266 * np.cos(2.0 * lat_rad) - 0.00028 * h / 1e3)
    wet = 0.002277 * (1255.0 / temp + 0.05) * vapour
    return np.where(el > 0.0, (dry + wet) / cos_z, 0.0)


@dataclass(frozen=True)
class CodeErrorModel:
    """Figures of the code variance: ``a_m``, ``b_m`` of a^2 + b^2 / sin^2(el) (RTKLIB's
    defaults, 0.3 m each), the relative error of the iono model and the zenith error of
    the tropo model (m)."""

    a_m: float = 0.3
    b_m: float = 0.3
    iono_rel: float = 0.5
    tropo_m: float = 0.3


def code_variance_m2(
    el: FloatArray, iono_m: FloatArray, tropo_used: bool, model: CodeErrorModel | None = None
) -> FloatArray:
    """Variance (m^2) of each pseudorange: measurement a^2 + b^2/sin^2(el), plus
    (iono_rel * iono)^2 and (tropo_m / (sin el + 0.1))^2 when the tropo model is applied
    (its unmodelled part; RTKLIB ``ERR_SAAS``)."""
    m = model or CodeErrorModel()
    s = np.maximum(np.sin(el), 0.05)
    var = m.a_m**2 + (m.b_m / s) ** 2
    var = var + (m.iono_rel * iono_m) ** 2
    if tropo_used:
        var = var + (m.tropo_m / (s + 0.1)) ** 2
    return np.asarray(var, dtype=np.float64)
