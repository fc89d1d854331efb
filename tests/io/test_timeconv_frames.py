"""Known answers: GPS week/tow <-> calendar, UTC <-> GPST across a leap second, ENU."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from coopproc import frames, timeconv


def _cal(text: str) -> np.datetime64:
    return np.datetime64(text, "ns")


@pytest.mark.parametrize(
    ("week", "tow", "calendar"),
    [
        (0, 0.0, "1980-01-06T00:00:00"),
        (2048, 0.0, "2019-04-07T00:00:00"),  # second week-number rollover
        (2178, 432000.0, "2021-10-08T00:00:00"),
        (2178, 432000.5, "2021-10-08T00:00:00.500"),
    ],
)
def test_week_tow_calendar(week: int, tow: float, calendar: str) -> None:
    gpst = timeconv.week_tow_to_gpst(week, tow)
    assert timeconv.gpst_to_calendar(gpst) == _cal(calendar)
    assert timeconv.calendar_to_gpst(_cal(calendar)) == pytest.approx(gpst)
    w, t = timeconv.gpst_to_week_tow(gpst)
    assert (int(w), float(t)) == (week, pytest.approx(tow))


def test_utc_to_gpst_across_the_2017_leap_second() -> None:
    before = timeconv.utc_calendar_to_gpst(_cal("2016-12-31T23:59:59"))
    after = timeconv.utc_calendar_to_gpst(_cal("2017-01-01T00:00:00"))
    assert timeconv.gpst_to_calendar(before) == _cal("2017-01-01T00:00:16")
    assert timeconv.gpst_to_calendar(after) == _cal("2017-01-01T00:00:18")
    assert after - before == pytest.approx(2.0)  # 23:59:60 UTC was inserted


def test_unix_gpst_known_answer_and_inverse() -> None:
    unix = np.array([315964800.0, 1483228799.0, 1483228800.0, 1633651200.25])
    gpst = timeconv.unix_to_gpst(unix)
    assert gpst[0] == 0.0
    assert gpst[2] == 1483228800.0 - 315964800.0 + 18.0
    assert gpst[1] == 1483228799.0 - 315964800.0 + 17.0
    np.testing.assert_allclose(timeconv.gpst_to_unix(gpst), unix, atol=1e-6, rtol=0)


def test_leap_seconds_table_values() -> None:
    assert timeconv.leap_seconds_at_utc(0.0) == 0.0
    utc_2009 = float(timeconv.calendar_to_gpst(_cal("2009-01-01T00:00:00")))
    assert timeconv.leap_seconds_at_utc(utc_2009 - 1) == 14.0
    assert timeconv.leap_seconds_at_utc(utc_2009) == 15.0
    assert timeconv.leap_seconds_at_gpst(timeconv.week_tow_to_gpst(2178, 0)) == 18.0


def test_geodetic_ecef_known_answers() -> None:
    a, b = 6378137.0, 6356752.314245
    xyz = frames.geodetic2ecef([[0.0, 0.0, 0.0], [90.0, 0.0, 0.0], [0.0, 90.0, 100.0]])
    np.testing.assert_allclose(xyz, [[a, 0, 0], [0, 0, b], [0, a + 100.0, 0]], atol=1e-3)
    back = frames.ecef2geodetic(xyz)
    np.testing.assert_allclose(back[:, 2], [0.0, 0.0, 100.0], atol=1e-6)


def test_wgs84_constants_are_pymap3d_s_ellipsoid() -> None:
    # The one definition (frames.WGS84_*) the numba kernels read must be the ellipsoid
    # pymap3d converts on: a and b (b = a (1 - f)) to 0.1 mm, e^2 to 1e-15.
    ell = pymap3d.Ellipsoid.from_name("wgs84")
    assert ell.semimajor_axis == frames.WGS84_A
    assert pytest.approx(ell.semiminor_axis, abs=1e-4) == frames.WGS84_A * (1.0 - frames.WGS84_F)
    assert pytest.approx(ell.flattening, rel=1e-9) == frames.WGS84_F
    assert pytest.approx(ell.eccentricity**2, abs=1e-15) == frames.WGS84_E2
    assert pytest.approx(6.69437999014e-3, abs=1e-14) == frames.WGS84_E2  # NIMA TR8350.2


def test_enu_of_small_offsets_at_the_equator() -> None:
    # 0.001 deg of latitude at the equator = M * dlat, M = a (1 - e^2) = 6335439.327 m;
    # 0.001 deg of longitude = a * dlon.
    origin = (0.0, 0.0, 0.0)
    enu = frames.geodetic2enu([[0.001, 0.0, 0.0], [0.0, 0.001, 0.0]], origin)
    assert enu[0, 1] == pytest.approx(6335439.327 * np.radians(0.001), abs=2e-3)
    assert enu[1, 0] == pytest.approx(6378137.0 * np.radians(0.001), abs=2e-3)
    assert abs(enu[0, 0]) < 1e-6 and abs(enu[1, 1]) < 1e-6


def test_surveyed_point_enu_round_trip() -> None:
    # Zhengzhou test site of paper 000 (34.7980 N, 113.6590 E, 110 m) and a point
    # 100 m east, 200 m north, 3 m up of it.
    origin = (34.7980, 113.6590, 110.0)
    llh = frames.enu2geodetic([[100.0, 200.0, 3.0]], origin)
    # Meridian radius M = a (1 - e^2) / (1 - e^2 sin^2 lat)^1.5, plus the height.
    e2 = 6.69437999014e-3
    m = 6378137.0 * (1 - e2) / (1 - e2 * np.sin(np.radians(34.798)) ** 2) ** 1.5 + 110.0
    assert llh[0, 0] == pytest.approx(34.7980 + np.degrees(200.0 / m), abs=2e-8)
    np.testing.assert_allclose(frames.geodetic2enu(llh, origin), [[100.0, 200.0, 3.0]], atol=1e-6)
    xyz = frames.enu2ecef([[100.0, 200.0, 3.0]], origin)
    np.testing.assert_allclose(frames.ecef2enu(xyz, origin), [[100.0, 200.0, 3.0]], atol=1e-6)


def test_ecef_covariance_rotation_at_a_pole_swaps_axes() -> None:
    # At lat 90, lon 0: east = +y, north = -x, up = +z.
    cov = np.diag([4.0, 9.0, 16.0])[None]
    sigma = frames.ecef_cov2enu_sigma(cov, (90.0, 0.0, 0.0))
    np.testing.assert_allclose(sigma[0], [3.0, 2.0, 4.0], atol=1e-9)
