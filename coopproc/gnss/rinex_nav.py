"""RINEX 2.x and 3.x GPS navigation files (broadcast ephemerides) -> GpsEphemerides.

Own fixed-column parser (see docs/methods-gnss.md for why not georinex / gnss-lib-py):

- RINEX 2 (``*.yyn``, type ``N``): records of 8 lines, the first ``I2,5I3,F5.1,3D19.12``
  (PRN, toc, af0 af1 af2), then 7 lines of ``3X,4D19.12``;
- RINEX 3 (``*_MN.rnx``, type ``N`` with system ``G`` or ``M``): the first line
  ``A1,I2,1X,I4,5(1X,I2),3D19.12``, then ``4X,4D19.12``; records of other systems are
  skipped (GLONASS and SBAS 4 lines, the others 8);
- header: ``ION ALPHA`` / ``ION BETA`` (RINEX 2) or ``IONOSPHERIC CORR`` ``GPSA`` / ``GPSB``
  (RINEX 3), the Klobuchar coefficients.

Numbers may use ``D`` or ``E`` exponents; blank fields read as 0 (RINEX allows trailing
blanks). A malformed number or a record cut short raises a one-line
:class:`~coopproc.errors.InputError` naming file and line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coopproc import timeconv
from coopproc.errors import InputError
from coopproc.gnss.ephemeris import GpsEphemerides

__all__ = ["read_nav", "read_navs"]

_WEEK_S = 604800.0
_LINES = {"G": 8, "E": 8, "C": 8, "J": 8, "I": 8, "R": 4, "S": 4}


def _num(text: str, path: Path, line: int, what: str) -> float:
    s = text.strip().replace("D", "E").replace("d", "e")
    if not s:
        return 0.0
    try:
        return float(s)
    except ValueError:
        raise InputError(
            path, f"{what}: {s!r} is not a number (expected a D19.12 field)", line=line
        ) from None


def _fields(text: str, start: int, count: int, path: Path, line: int) -> list[float]:
    return [
        _num(text[start + 19 * k : start + 19 * (k + 1)], path, line, f"field {k + 1}")
        for k in range(count)
    ]


def _header(
    lines: list[str], path: Path
) -> tuple[float, str, int, tuple[float, ...] | None, tuple[float, ...] | None]:
    """(version, system, first record line index, ion alpha, ion beta)."""
    if not lines or "RINEX VERSION / TYPE" not in lines[0][60:]:
        raise InputError(path, "not a RINEX file: no 'RINEX VERSION / TYPE' line", line=1)
    version = _num(lines[0][:9], path, 1, "RINEX version")
    kind = lines[0][20:21].upper()
    system = lines[0][40:41].upper() or "G"
    if kind != "N" or (version >= 3 and system not in "GM "):
        raise InputError(
            path,
            f"RINEX type {lines[0][20:40].strip()!r} {lines[0][40:60].strip()!r}; expected "
            "GPS navigation data ('N', system G or M)",
            line=1,
        )
    alpha = beta = None
    for i, text in enumerate(lines):
        label = text[60:].strip()
        if label == "END OF HEADER":
            return version, system, i + 1, alpha, beta
        if label == "ION ALPHA":
            alpha = tuple(
                _num(text[2 + 12 * k : 14 + 12 * k], path, i + 1, "ION ALPHA") for k in range(4)
            )
        elif label == "ION BETA":
            beta = tuple(
                _num(text[2 + 12 * k : 14 + 12 * k], path, i + 1, "ION BETA") for k in range(4)
            )
        elif label == "IONOSPHERIC CORR" and text[:4] in ("GPSA", "GPSB"):
            values = tuple(
                _num(text[5 + 12 * k : 17 + 12 * k], path, i + 1, "IONOSPHERIC CORR")
                for k in range(4)
            )
            if text[:4] == "GPSA":
                alpha = values
            else:
                beta = values
    raise InputError(path, "truncated header: no 'END OF HEADER' line", line=len(lines))


def _toc(parts: list[str], path: Path, line: int) -> float:
    """GPST seconds of a record's 'yy mm dd hh mm ss' (or yyyy ...)."""
    try:
        year, month, day, hour, minute = (int(p) for p in parts[:5])
        second = float(parts[5])
    except (ValueError, IndexError):
        raise InputError(
            path, f"epoch {' '.join(parts)!r}; expected 'yy mm dd hh mm ss.s'", line=line
        ) from None
    if year < 100:
        year += 1900 if year >= 80 else 2000
    try:
        day0 = np.datetime64(f"{year:04d}-{month:02d}-{day:02d}", "ns")
    except ValueError:
        raise InputError(path, f"date {year}-{month}-{day} does not exist", line=line) from None
    base = float(timeconv.calendar_to_gpst(np.array([day0]))[0])
    return base + hour * 3600.0 + minute * 60.0 + second


def read_nav(path: str | Path) -> GpsEphemerides:
    """The GPS ephemerides of one RINEX 2/3 navigation file; raises InputError."""
    p = Path(path)
    try:
        lines = p.read_text(encoding="ascii", errors="replace").splitlines()
    except OSError as err:
        raise InputError(p, f"cannot read ({err.strerror or type(err).__name__})") from err
    version, _system, i, alpha, beta = _header(lines, p)
    v3 = version >= 3
    skip = 4 if v3 else 3
    rows: list[list[float]] = []
    while i < len(lines):
        text = lines[i]
        if not text.strip():
            i += 1
            continue
        sys_char = text[0] if v3 else "G"
        count = _LINES.get(sys_char, 0) if v3 else 8
        if count == 0:
            raise InputError(
                p, f"record starts with {text[:3]!r}; expected a satellite like 'G01'", line=i + 1
            )
        if i + count > len(lines):
            raise InputError(
                p,
                f"truncated: the record starting here has {len(lines) - i} of {count} lines",
                line=i + 1,
            )
        if sys_char != "G":
            i += count
            continue
        head = 23 if v3 else 22
        try:
            prn = int(text[1:3] if v3 else text[0:2])
        except ValueError:
            raise InputError(p, f"PRN {text[:3]!r} is not a number", line=i + 1) from None
        toc = _toc(text[3 if v3 else 2 : head].split(), p, i + 1)
        values = [float(prn), toc, *_fields(text, head, 3, p, i + 1)]
        for k in range(1, 8):
            orbit = lines[i + k]
            if orbit[:skip].strip():
                raise InputError(
                    p,
                    f"broadcast orbit line {k} starts with {orbit[:skip]!r}; expected "
                    f"{skip} blanks (record of PRN {prn} cut short?)",
                    line=i + k + 1,
                )
            n_fields = 2 if k == 7 else 4
            values += _fields(orbit, skip, n_fields, p, i + k + 1)
        rows.append(values)
        i += 8
    return _to_ephemerides(np.array(rows, dtype=np.float64).reshape(-1, 31), p, alpha, beta)


def _to_ephemerides(
    a: np.ndarray,
    path: Path,
    alpha: tuple[float, ...] | None,
    beta: tuple[float, ...] | None,
) -> GpsEphemerides:
    # columns: prn toc af0 af1 af2 | iode crs dn m0 | cuc e cus sqrtA | toe cic OMEGA0 cis |
    # i0 crc omega OMEGADOT | idot l2codes week l2p | acc health tgd iodc | ttx fit
    week = a[:, 23]
    toc = a[:, 1]
    toe = week * _WEEK_S + a[:, 13]
    toe += np.round((toc - toe) / _WEEK_S) * _WEEK_S  # the week of toe is the one nearest toc
    fit = a[:, 30]
    return GpsEphemerides(
        prn=a[:, 0].astype(np.int64),
        toc_gpst_s=toc,
        toe_gpst_s=toe,
        af0=a[:, 2],
        af1=a[:, 3],
        af2=a[:, 4],
        iode=a[:, 5].astype(np.int64),
        crs=a[:, 6],
        delta_n=a[:, 7],
        m0=a[:, 8],
        cuc=a[:, 9],
        e=a[:, 10],
        cus=a[:, 11],
        sqrt_a=a[:, 12],
        cic=a[:, 14],
        omega0=a[:, 15],
        cis=a[:, 16],
        i0=a[:, 17],
        crc=a[:, 18],
        omega=a[:, 19],
        omega_dot=a[:, 20],
        idot=a[:, 21],
        week=week.astype(np.int64),
        health=a[:, 26].astype(np.int64),
        tgd=a[:, 27],
        # hours; some writers put the fit flag (0/1) here: anything below 4 h reads as 4 h
        fit_interval_h=np.maximum(fit, 4.0),
        iono_alpha=None if alpha is None else (alpha[0], alpha[1], alpha[2], alpha[3]),
        iono_beta=None if beta is None else (beta[0], beta[1], beta[2], beta[3]),
        source=str(path),
    )


def read_navs(paths: list[str | Path] | list[Path]) -> GpsEphemerides:
    """The GPS ephemerides of one or more navigation files, merged (duplicates once)."""
    parts = [read_nav(p) for p in paths]
    if not parts:
        raise InputError(None, "no navigation file given")
    merged = GpsEphemerides.concatenate(parts)
    if len(merged) == 0:
        raise InputError(parts[0].source, "no GPS ephemeris records in the navigation file(s)")
    return merged
