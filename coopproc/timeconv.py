"""GPS time <-> calendar and UTC <-> GPST conversions, vectorized over numpy arrays.

Absolute times are carried as **GPST seconds since the GPS epoch** (1980-01-06 00:00:00
GPST), float64. Calendar times are ``numpy.datetime64`` on a leap-second-free timeline,
as RTKLIB prints them: a GPST calendar time is GPST, a UTC calendar time is UTC.

GPST = UTC + (GPS-UTC leap seconds); the table below is IERS Bulletin C up to the leap
second of 2017-01-01 (18 s), still current.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from coopproc.model import FloatArray

__all__ = [
    "GPS_EPOCH",
    "SECONDS_PER_WEEK",
    "UNIX_AT_GPS_EPOCH_S",
    "calendar_to_gpst",
    "gpst_to_calendar",
    "gpst_to_unix",
    "gpst_to_week_tow",
    "leap_seconds_at_gpst",
    "leap_seconds_at_utc",
    "unix_to_gpst",
    "utc_calendar_to_gpst",
    "week_tow_to_gpst",
]

GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")
SECONDS_PER_WEEK = 604800.0
#: Unix seconds at the GPS epoch (1980-01-06 00:00:00 UTC; GPS-UTC was 0 then).
UNIX_AT_GPS_EPOCH_S = 315964800.0

# (UTC date from which it applies, GPS-UTC seconds). IERS Bulletin C.
_LEAP_TABLE: tuple[tuple[str, int], ...] = (
    ("1981-07-01", 1),
    ("1982-07-01", 2),
    ("1983-07-01", 3),
    ("1985-07-01", 4),
    ("1988-01-01", 5),
    ("1990-01-01", 6),
    ("1991-01-01", 7),
    ("1992-07-01", 8),
    ("1993-07-01", 9),
    ("1994-07-01", 10),
    ("1996-01-01", 11),
    ("1997-07-01", 12),
    ("1999-01-01", 13),
    ("2006-01-01", 14),
    ("2009-01-01", 15),
    ("2012-07-01", 16),
    ("2015-07-01", 17),
    ("2017-01-01", 18),
)
# Start of each leap period as UTC seconds since the GPS epoch (a UTC timeline).
_LEAP_UTC_S = np.array(
    [(np.datetime64(d, "ns") - GPS_EPOCH) / np.timedelta64(1, "s") for d, _ in _LEAP_TABLE]
)
_LEAP_VALUE = np.array([v for _, v in _LEAP_TABLE], dtype=np.float64)
# The same instants on the GPST timeline (GPST = UTC + leap).
_LEAP_GPST_S = _LEAP_UTC_S + _LEAP_VALUE


def _lookup(edges: FloatArray, t: FloatArray) -> FloatArray:
    idx = np.searchsorted(edges, t, side="right") - 1
    return np.where(idx >= 0, _LEAP_VALUE[np.clip(idx, 0, None)], 0.0)


def leap_seconds_at_utc(utc_since_gps_epoch_s: ArrayLike) -> FloatArray:
    """GPS-UTC (s) at UTC times given as UTC seconds since 1980-01-06 00:00:00 UTC."""
    return _lookup(_LEAP_UTC_S, np.asarray(utc_since_gps_epoch_s, dtype=np.float64))


def leap_seconds_at_gpst(gpst_s: ArrayLike) -> FloatArray:
    """GPS-UTC (s) at GPST times (seconds since the GPS epoch)."""
    return _lookup(_LEAP_GPST_S, np.asarray(gpst_s, dtype=np.float64))


def calendar_to_gpst(calendar: ArrayLike) -> FloatArray:
    """GPST seconds since the GPS epoch from GPST calendar times (``datetime64``)."""
    cal = np.asarray(calendar, dtype="datetime64[ns]")
    return ((cal - GPS_EPOCH) / np.timedelta64(1, "ns")).astype(np.float64) * 1e-9


def utc_calendar_to_gpst(calendar: ArrayLike) -> FloatArray:
    """GPST seconds since the GPS epoch from UTC calendar times (leap seconds added)."""
    utc_s = calendar_to_gpst(calendar)
    return utc_s + leap_seconds_at_utc(utc_s)


def gpst_to_calendar(gpst_s: ArrayLike) -> NDArray[np.datetime64]:
    """GPST calendar times (``datetime64[ns]``) from GPST seconds since the GPS epoch."""
    ns = np.round(np.asarray(gpst_s, dtype=np.float64) * 1e9).astype(np.int64)
    return GPS_EPOCH + ns.astype("timedelta64[ns]")


def week_tow_to_gpst(week: ArrayLike, tow_s: ArrayLike) -> FloatArray:
    """GPST seconds since the GPS epoch from GPS week and time of week (s)."""
    return np.asarray(week, dtype=np.float64) * SECONDS_PER_WEEK + np.asarray(
        tow_s, dtype=np.float64
    )


def gpst_to_week_tow(gpst_s: ArrayLike) -> tuple[NDArray[np.int64], FloatArray]:
    """GPS week and time of week (s) from GPST seconds since the GPS epoch."""
    t = np.asarray(gpst_s, dtype=np.float64)
    week = np.floor(t / SECONDS_PER_WEEK).astype(np.int64)
    return week, t - week * SECONDS_PER_WEEK


def gpst_to_unix(gpst_s: ArrayLike) -> FloatArray:
    """Unix seconds (UTC) from GPST seconds since the GPS epoch (leap seconds removed)."""
    t = np.asarray(gpst_s, dtype=np.float64)
    return t - leap_seconds_at_gpst(t) + UNIX_AT_GPS_EPOCH_S


def unix_to_gpst(unix_s: ArrayLike) -> FloatArray:
    """GPST seconds since the GPS epoch from Unix seconds (UTC; leap seconds added)."""
    utc_s = np.asarray(unix_s, dtype=np.float64) - UNIX_AT_GPS_EPOCH_S
    return utc_s + leap_seconds_at_utc(utc_s)
