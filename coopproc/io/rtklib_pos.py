"""RTKLIB solution files (``ref_<ID>.pos``, as rtkpost / rnx2rtkp write them).

Header-driven: ``%`` lines, the last of which names the columns, e.g.::

    %  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m) ...

The first header token is the time system (``GPST``, ``UTC`` or ``JST`` = UTC+9 h); each
epoch's time is two fields, ``YYYY/MM/DD HH:MM:SS.SSS`` or ``week tow``. Positions are
``latitude(deg) longitude(deg) height(m)`` or ``x-ecef(m) y-ecef(m) z-ecef(m)``; then
``Q ns`` and the sd columns (``sdn sde sdu sdne sdeu sdun`` or ``sdx sdy sdz sdxy sdyz
sdzx``; RTKLIB writes signed square roots of covariances), ``age ratio``, and in newer
versions velocity columns, which are ignored. Times come out as GPST seconds since the
GPS epoch (``time_kind = "gpst"``); the session assembly converts them to the session
time base and applies the Q filter.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from coopproc import timeconv
from coopproc.errors import InputError
from coopproc.io._common import (
    PARSE_ERRORS,
    InputProblems,
    Locator,
    RawTrajectory,
    check_trajectory_times,
    numeric_column,
    parser_error,
)
from coopproc.model import FloatArray

__all__ = ["read_pos", "write_pos"]

_TIME_SYSTEMS = ("GPST", "UTC", "JST")
_LLH = ("latitude(deg)", "longitude(deg)", "height(m)")
_ECEF = ("x-ecef(m)", "y-ecef(m)", "z-ecef(m)")
_SD_LLH = ("sde(m)", "sdn(m)", "sdu(m)")  # east, north, up order
_SD_ECEF = ("sdx(m)", "sdy(m)", "sdz(m)", "sdxy(m)", "sdyz(m)", "sdzx(m)")


def _scan_header(path: Path) -> tuple[int, list[str], str]:
    """(first data line, column names, time system) from the ``%`` header."""
    columns: list[str] | None = None
    system = ""
    first_data = 0
    with open(path, encoding="utf-8") as fh:
        for number, text in enumerate(fh, start=1):
            stripped = text.strip()
            if not stripped:
                continue
            if stripped.startswith("%"):
                tokens = stripped.lstrip("%").split()
                if tokens and tokens[0] in _TIME_SYSTEMS and len(tokens) > 3:
                    system, columns = tokens[0], tokens[1:]
                continue
            first_data = number
            break
    if columns is None:
        raise InputError(
            path,
            "no RTKLIB column header; expected a line like "
            "'%  GPST  latitude(deg) longitude(deg) height(m)  Q  ns ...'",
        )
    if first_data == 0:
        raise InputError(path, "no solution epochs after the header; expected at least one")
    return first_data, columns, system


def read_pos(path: str | Path, platform: str) -> RawTrajectory:
    """Read an RTKLIB .pos file of ``platform``; raises InputError."""
    p = Path(path)
    try:
        first_data, columns, system = _scan_header(p)
    except InputError:
        raise
    except PARSE_ERRORS as err:
        raise InputError(p, f"cannot read as RTKLIB .pos ({type(err).__name__})") from err
    if set(_LLH) <= set(columns):
        form: Literal["llh", "ecef"] = "llh"
        pos_cols = _LLH
    elif set(_ECEF) <= set(columns):
        form, pos_cols = "ecef", _ECEF
    else:
        found = " ".join(columns[:3])
        raise InputError(
            p,
            f"position columns '{found}' not supported; expected latitude(deg) longitude(deg) "
            "height(m) or x-ecef(m) y-ecef(m) z-ecef(m) (set RTKLIB output to decimal degrees "
            "or ECEF)",
            line=first_data - 1,
        )
    if "Q" not in columns:
        raise InputError(p, "no Q column in the header; expected 'Q ns' after the positions")
    names = ["t1", "t2", *columns]
    try:
        frame = pd.read_csv(
            p,
            sep=r"\s+",
            comment="%",
            header=None,
            names=names,
            # times as text; the numbers parsed by the C reader (a column with a stray
            # token stays text and numeric_column reports its row)
            dtype={"t1": str, "t2": str},
            engine="c",
            encoding="utf-8",
        )
    except pd.errors.ParserError as err:
        raise parser_error(p, err, "the columns of the % header") from err
    except PARSE_ERRORS as err:
        raise InputError(p, f"cannot read as RTKLIB .pos ({type(err).__name__})") from err
    where = Locator(str(p), lines=_pos_lines(p, first_data))
    if len(frame) == 0:
        raise where.error("no solution epochs; expected at least one")
    short = frame[pos_cols[2]].isna().to_numpy()
    if short.any():
        idx = np.flatnonzero(short)
        raise where.error(
            f"too few fields; expected time, {' '.join(pos_cols)}, Q ...", int(idx[0]), idx.size
        )
    problems: list[InputError] = []
    gpst = _times(frame, system, where, problems)
    position = np.column_stack([numeric_column(frame, c, where, problems) for c in pos_cols])
    quality = numeric_column(frame, "Q", where, problems)
    sigma = cov = None
    if form == "llh" and set(_SD_LLH) <= set(columns):
        sigma = np.abs(
            np.column_stack([numeric_column(frame, c, where, problems) for c in _SD_LLH])
        )
    elif form == "ecef" and set(_SD_ECEF) <= set(columns):
        sd = np.column_stack([numeric_column(frame, c, where, problems) for c in _SD_ECEF])
        cov = _ecef_cov(sd)
    if problems:
        raise InputProblems(problems)
    if form == "llh":
        bad = (np.abs(position[:, 0]) > 90) | (np.abs(position[:, 1]) > 360)
        if bad.any():
            idx = np.flatnonzero(bad)
            raise where.error(
                f"latitude/longitude {position[idx[0], 0]}, {position[idx[0], 1]} out of range",
                int(idx[0]),
                idx.size,
            )
    if sigma is not None and not sigma.any():
        sigma = None  # RTKLIB writes zeros when it has no sd
    if cov is not None and not cov.any():
        cov = None
    raw = RawTrajectory(
        platform=platform,
        time_s=gpst,
        position=position,
        form=form,
        source=str(p),
        time_kind="gpst",
        sigma_enu_m=sigma,
        cov_ecef_m2=cov,
        quality=quality.astype(np.int64),
        gps_week=int(timeconv.gpst_to_week_tow(gpst[:1])[0][0]),
    )
    return check_trajectory_times(raw, where)


def _times(
    frame: pd.DataFrame, system: str, where: Locator, problems: list[InputError]
) -> FloatArray:
    """GPST seconds since the GPS epoch of every epoch."""
    first = str(frame["t1"].iloc[0])
    if "/" in first:
        text = frame["t1"].astype(str) + " " + frame["t2"].astype(str)
        cal = pd.to_datetime(text, format="%Y/%m/%d %H:%M:%S.%f", errors="coerce")
        bad = cal.isna().to_numpy()
        if bad.any():
            cal2 = pd.to_datetime(text, format="%Y/%m/%d %H:%M:%S", errors="coerce")
            cal = cal.where(~bad, cal2)
            bad = cal.isna().to_numpy()
        if bad.any():
            idx = np.flatnonzero(bad)
            problems.append(
                where.error(
                    f"time {text.iloc[idx[0]][:40]!r}; expected 'YYYY/MM/DD HH:MM:SS.SSS'",
                    int(idx[0]),
                    idx.size,
                )
            )
            return np.zeros(len(frame))
        values = cal.to_numpy(dtype="datetime64[ns]")
        if system == "GPST":
            return timeconv.calendar_to_gpst(values)
        if system == "JST":
            values = values - np.timedelta64(9, "h")
        return timeconv.utc_calendar_to_gpst(values)
    week = numeric_column(frame, "t1", where, problems)
    tow = numeric_column(frame, "t2", where, problems)
    if system != "GPST":
        problems.append(where.error(f"'week tow' times in {system}; expected GPST"))
    bad = (tow < 0) | (tow >= timeconv.SECONDS_PER_WEEK) | (week < 0) | (week != np.round(week))
    if bad.any():
        idx = np.flatnonzero(bad)
        problems.append(
            where.error(
                f"time '{frame['t1'].iloc[idx[0]]} {frame['t2'].iloc[idx[0]]}'; expected "
                "'week tow' with 0 <= tow < 604800",
                int(idx[0]),
                idx.size,
            )
        )
    return timeconv.week_tow_to_gpst(week, tow)


def _ecef_cov(sd: FloatArray) -> FloatArray:
    """(n, 3, 3) covariance from RTKLIB's signed square roots sdx sdy sdz sdxy sdyz sdzx."""
    var = np.sign(sd) * sd**2
    cov = np.empty((sd.shape[0], 3, 3))
    cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2] = var[:, 0], var[:, 1], var[:, 2]
    cov[:, 0, 1] = cov[:, 1, 0] = var[:, 3]
    cov[:, 1, 2] = cov[:, 2, 1] = var[:, 4]
    cov[:, 2, 0] = cov[:, 0, 2] = var[:, 5]
    return cov


def _pos_lines(path: Path, first_data: int) -> Callable[[int], int]:
    cache: list[int] = []

    def line_of(row: int) -> int:
        if not cache:
            with open(path, encoding="utf-8", errors="replace") as fh:
                for number, text in enumerate(fh, start=1):
                    s = text.strip()
                    if number >= first_data and s and not s.startswith("%"):
                        cache.append(number)
        return cache[row] if row < len(cache) else first_data + row

    return line_of


def write_pos(
    path: str | Path,
    gpst_s: FloatArray,
    llh_or_ecef: FloatArray,
    *,
    form: Literal["llh", "ecef"] = "llh",
    quality: np.ndarray | None = None,
    sigma_enu_m: FloatArray | None = None,
    time_system: Literal["GPST", "UTC"] = "GPST",
    time_format: Literal["calendar", "week_tow"] = "calendar",
    time_decimals: int = 3,
) -> Path:
    """Write an RTKLIB .pos file in RTKLIB's layout (rtkpost ver.2.4.3 header).

    ``gpst_s`` GPST seconds since the GPS epoch; positions lat/lon deg + height m or ECEF
    m; ``sigma_enu_m`` (n, 3) written as sde/sdn/sdu (geodetic form; the ECEF form writes
    zero sd, i.e. unknown); ``quality`` Q per epoch (default 1 = fix).
    """
    p = Path(path)
    n = gpst_s.shape[0]
    q = np.ones(n, dtype=np.int64) if quality is None else np.asarray(quality, dtype=np.int64)
    sd = (
        np.zeros((n, 6))
        if sigma_enu_m is None
        else np.column_stack(
            [sigma_enu_m[:, 1], sigma_enu_m[:, 0], sigma_enu_m[:, 2], np.zeros((n, 3))]
        )
    )
    if form == "ecef":
        sd = np.zeros((n, 6))
    if time_format == "week_tow":
        week, tow = timeconv.gpst_to_week_tow(gpst_s)
        times = [
            f"{w:4d} {s:{11 + time_decimals}.{time_decimals}f}"
            for w, s in zip(week, tow, strict=True)
        ]
        label = "GPST"
    else:
        t = (
            gpst_s
            if time_system == "GPST"
            else timeconv.gpst_to_unix(gpst_s) - timeconv.UNIX_AT_GPS_EPOCH_S
        )
        cal = timeconv.gpst_to_calendar(np.round(t, time_decimals))
        text = np.datetime_as_string(cal, unit="ms" if time_decimals == 3 else "us")
        times = [s.replace("-", "/").replace("T", " ") for s in text]
        label = time_system
    if form == "llh":
        cols = "latitude(deg) longitude(deg)  height(m)"
        sdcols = "sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m)"
        pos_fmt = "{:14.9f} {:14.9f} {:10.4f}"
    else:
        cols = "     x-ecef(m)      y-ecef(m)      z-ecef(m)"
        sdcols = "sdx(m)   sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m)"
        pos_fmt = "{:14.4f} {:14.4f} {:14.4f}"
    # rounded to the millisecond, not cut: 1317081600.013 s is 1317081600.0129998 as a
    # float, which a cut at the ms printed as .012 (integer ms, then the calendar)
    ms = np.round(np.asarray(gpst_s[[0, -1]], dtype=np.float64) * 1000.0).astype(np.int64)
    start, end = (
        s.replace("-", "/").replace("T", " ")
        for s in np.datetime_as_string(timeconv.GPS_EPOCH + ms.astype("timedelta64[ms]"), unit="ms")
    )
    lines = [
        "% program   : RTKPOST ver.2.4.3 b34 (coopproc writer)",
        f"% obs start : {start} GPST",
        f"% obs end   : {end} GPST",
        "% pos mode  : kinematic",
        "%",
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,"
        "ns=# of satellites)",
        f"%  {label:<22}{cols}   Q  ns   {sdcols} age(s)  ratio",
    ]
    for i in range(n):
        pos = pos_fmt.format(*llh_or_ecef[i])
        sds = " ".join(f"{v:8.4f}" for v in sd[i])
        lines.append(f"{times[i]} {pos} {q[i]:3d} {10:3d} {sds} {0.0:6.2f} {0.0:6.1f}")
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p
