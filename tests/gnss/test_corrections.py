"""Corrections: Saastamoinen's zenith delay at sea level, the Klobuchar night floor and
day peak, azimuth/elevation and the elevation weighting."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc import frames
from coopproc.gnss.corrections import (
    azel,
    code_variance_m2,
    ecef_to_llh,
    klobuchar_s,
    saastamoinen_m,
)

ALPHA = (1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08)  # GEONET 2005-04-02 header
BETA = (88060.0, 16380.0, -196600.0, -131100.0)


def test_saastamoinen_dry_zenith_delay_at_sea_level() -> None:
    # 0.0022768 * 1013.25 hPa / (1 - 0.00266 cos 90 deg) = 2.3070 m (the textbook ZHD)
    zenith = saastamoinen_m(np.radians(45.0), 0.0, np.array([np.pi / 2]), humidity=0.0)
    assert zenith[0] == pytest.approx(2.3070, abs=5e-4)
    slant = saastamoinen_m(np.radians(45.0), 0.0, np.radians(np.array([30.0])), humidity=0.0)
    assert slant[0] == pytest.approx(2 * zenith[0], rel=1e-9)
    wet = saastamoinen_m(np.radians(45.0), 0.0, np.array([np.pi / 2]))[0] - zenith[0]
    assert 0.05 < wet < 0.2  # 70 % humidity at 15 deg C: about a decimetre
    high = saastamoinen_m(np.radians(45.0), 3000.0, np.array([np.pi / 2]), humidity=0.0)
    assert high[0] == pytest.approx(2.3070 * (1 - 2.2557e-5 * 3000) ** 5.2568, rel=2e-3)
    assert saastamoinen_m(0.0, 20_000.0, np.array([1.0]))[0] == 0.0


def test_klobuchar_night_floor_and_day_peak() -> None:
    el = np.array([np.pi / 2])
    az = np.zeros(1)
    # local time = gps time + 4.32e4 * lon (semicircles): lon 0 -> midnight at t = 0
    night = klobuchar_s(0.0, 0.0, 0.0, az, el, ALPHA, BETA)[0]
    f = 1.0 + 16.0 * (0.53 - 0.5) ** 3
    assert night == pytest.approx(5e-9 * f, rel=1e-12)
    day = klobuchar_s(50400.0, 0.0, 0.0, az, el, ALPHA, BETA)[0]
    assert 3e-9 < day - night < 30e-9  # a few metres of delay at 14:00 local time
    low = klobuchar_s(50400.0, 0.0, 0.0, az, np.radians([10.0]), ALPHA, BETA)[0]
    assert low > 2.5 * day  # the obliquity factor
    # 14:00 local east of Greenwich is earlier in GPS time
    east = klobuchar_s(50400.0 - 4.32e4 * 0.5, 0.0, np.pi / 2, az, el, ALPHA, BETA)[0]
    assert east == pytest.approx(day, rel=0.2)


def test_azel_and_llh() -> None:
    rx = frames.geodetic2ecef([[35.0, 139.0, 50.0]])[0]
    lat, lon, h = ecef_to_llh(rx)
    assert (np.degrees(lat), np.degrees(lon), h) == pytest.approx((35.0, 139.0, 50.0), abs=1e-6)
    up = frames.geodetic2ecef([[35.0, 139.0, 20_000e3]])[0]
    north = frames.enu2ecef([[0.0, 1e6, 0.0]], (35.0, 139.0, 50.0))[0]
    az, el = azel(rx, np.vstack([up, north]))
    assert np.degrees(el[0]) == pytest.approx(90.0, abs=1e-6)
    assert np.degrees(az[1]) == pytest.approx(0.0, abs=1e-6) or np.degrees(az[1]) == pytest.approx(
        360.0, abs=1e-6
    )
    assert np.degrees(el[1]) == pytest.approx(0.0, abs=1e-6)


def test_low_satellites_weigh_less() -> None:
    var = code_variance_m2(np.radians([90.0, 30.0, 10.0]), np.zeros(3), tropo_used=False)
    assert var[0] == pytest.approx(0.18) and var[1] == pytest.approx(0.09 + 0.36)
    assert var[2] > var[1] > var[0]
