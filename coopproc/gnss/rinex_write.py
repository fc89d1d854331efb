"""RINEX writers: GPS observation files (3.04 or 2.11) and GPS navigation files (3.04 or 2.11).

Fixed-column formats of the RINEX standard (IGS/RTCM RINEX 3.04, 2.11):

- **Observation**: one GPS signal, L1 C/A: pseudorange ``C1C`` (m), carrier phase ``L1C``
  (cycles, optional), Doppler ``D1C`` (Hz, positive for approaching satellites) and
  ``S1C`` (C/N0, dB-Hz); RINEX 2.11 names them ``C1 L1 D1 S1``. Each value F14.3 with
  its loss-of-lock indicator (LLI: 1 = a new carrier-phase arc, ambiguity changed) and
  signal-strength indicator (SSI 1-9 = C/N0 / 6 dB-Hz, rounded down, within 1-9).
  Header: APPROX POSITION XYZ, INTERVAL, TIME OF FIRST OBS (GPS time). Resolution: 1 mm,
  0.001 cycle, 0.001 Hz, 0.001 dB-Hz; epoch times 0.1 microsecond.
- **Navigation** (GPS LNAV): the broadcast records of a
  :class:`~coopproc.gnss.ephemeris.GpsEphemerides` with the ionosphere (Klobuchar) header
  lines; 12 significant digits per value (D19.12), as the receivers' files give them.
  Fields the ephemerides do not hold are written as: codes on L2 0, L2 P flag 0, SV
  accuracy 2.0 m, IODC = IODE, transmission time = toe - 7200 s (not before the week).

No current date is written (PGM / RUN BY / DATE carries the first epoch), so the same
data give byte-identical files. Files are written atomically.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from coopproc.gnss.ephemeris import GpsEphemerides
from coopproc.io.outdir import write_text_atomic
from coopproc.model import FloatArray

__all__ = [
    "GPS_EPOCH",
    "L1_WAVELENGTH_M",
    "ObsTable",
    "gpst_to_calendar",
    "nav_text",
    "obs_text",
    "write_nav",
    "write_obs",
]

#: The GPS time origin (GPST seconds count from here).
GPS_EPOCH = datetime(1980, 1, 6)
#: GPS L1 carrier frequency (Hz) and wavelength (m), IS-GPS-200.
L1_FREQ_HZ = 1575.42e6
L1_WAVELENGTH_M = 299792458.0 / L1_FREQ_HZ
_WEEK_S = 604800.0
_OBS3 = ("C1C", "L1C", "D1C", "S1C")
_OBS2 = ("C1", "L1", "D1", "S1")


@dataclass(frozen=True, eq=False)
class ObsTable:
    """GPS L1 observations of one receiver, epoch by satellite.

    ``time_gpst_s`` (n,) receiver epochs as GPST seconds since 1980-01-06; ``prn`` (m,)
    the satellites (columns); ``code_m``, ``phase_cycles``, ``doppler_hz``, ``cn0_dbhz``
    (n, m) with NaN where the satellite is not observed (``phase_cycles`` None: no
    carrier phase); ``lli`` (n, m) loss-of-lock flags of the phase (0 or 1; None: all 0).
    """

    marker: str
    approx_ecef_m: tuple[float, float, float]
    interval_s: float
    time_gpst_s: FloatArray
    prn: NDArray[np.int64]
    code_m: FloatArray
    doppler_hz: FloatArray
    cn0_dbhz: FloatArray
    phase_cycles: FloatArray | None = None
    lli: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        shape = (self.time_gpst_s.shape[0], self.prn.shape[0])
        arrays = [self.code_m, self.doppler_hz, self.cn0_dbhz, self.phase_cycles, self.lli]
        for arr in arrays:
            if arr is not None and arr.shape != shape:
                raise ValueError(f"observation array of shape {arr.shape}, expected {shape}")
        if np.any(np.diff(self.time_gpst_s) <= 0):
            raise ValueError("observation epochs must increase")


def gpst_to_calendar(t_gpst_s: float) -> tuple[int, int, int, int, int, float]:
    """(year, month, day, hour, minute, second) of GPST seconds since 1980-01-06,
    rounded to 0.1 microsecond."""
    ticks = round(t_gpst_s * 1e7)
    whole, frac = divmod(ticks, 10_000_000)
    d = GPS_EPOCH + timedelta(seconds=whole)
    return d.year, d.month, d.day, d.hour, d.minute, d.second + frac / 1e7


def _hline(content: str, label: str) -> str:
    return f"{content:<60.60}{label}\n"


def _ssi(cn0: float) -> int:
    return min(9, max(1, int(cn0 // 6.0)))


def _field(value: float, lli: int, ssi: int) -> str:
    if not math.isfinite(value):
        return " " * 16
    text = f"{value:14.3f}"
    if len(text) > 14:
        raise ValueError(f"observation value {value} does not fit RINEX F14.3")
    return text + (str(lli) if lli else " ") + str(ssi)


def _obs_fields(obs: ObsTable, i: int, j: int, with_phase: bool) -> list[str]:
    ssi = _ssi(float(obs.cn0_dbhz[i, j])) if math.isfinite(obs.cn0_dbhz[i, j]) else 0
    lli = int(obs.lli[i, j]) if obs.lli is not None else 0
    out = [_field(float(obs.code_m[i, j]), 0, ssi)]
    if with_phase:
        assert obs.phase_cycles is not None
        out.append(_field(float(obs.phase_cycles[i, j]), lli, ssi))
    out.append(_field(float(obs.doppler_hz[i, j]), 0, ssi))
    out.append(_field(float(obs.cn0_dbhz[i, j]), 0, 0)[:14] + "  ")
    return out


def _obs_header(obs: ObsTable, version: int, types: Sequence[str]) -> str:
    y, mo, d, h, mi, s = gpst_to_calendar(float(obs.time_gpst_s[0]))
    stamp = f"{y:04d}{mo:02d}{d:02d} {h:02d}{mi:02d}{int(s):02d} GPS"
    x, yy, z = obs.approx_ecef_m
    lines = []
    if version == 3:
        lines.append(
            _hline(
                f"{3.04:9.2f}{'':11}{'OBSERVATION DATA':20}{'G: GPS':20}", "RINEX VERSION / TYPE"
            )
        )
    else:
        lines.append(
            _hline(
                f"{2.11:9.2f}{'':11}{'OBSERVATION DATA':20}{'G (GPS)':20}", "RINEX VERSION / TYPE"
            )
        )
    lines.append(_hline(f"{'coopproc':20}{'coopproc':20}{stamp}", "PGM / RUN BY / DATE"))
    lines.append(_hline("simulated by coopproc (not a real recording)", "COMMENT"))
    lines.append(_hline(obs.marker, "MARKER NAME"))
    if version == 3:
        lines.append(_hline("NON_GEODETIC", "MARKER TYPE"))
    lines.append(_hline(f"{'coopproc':20}{'coopproc':40}", "OBSERVER / AGENCY"))
    lines.append(_hline(f"{'0':20}{'SIMULATED':20}{'0':20}", "REC # / TYPE / VERS"))
    lines.append(_hline(f"{'0':20}{'SIMULATED':20}", "ANT # / TYPE"))
    lines.append(_hline(f"{x:14.4f}{yy:14.4f}{z:14.4f}", "APPROX POSITION XYZ"))
    lines.append(_hline(f"{0.0:14.4f}{0.0:14.4f}{0.0:14.4f}", "ANTENNA: DELTA H/E/N"))
    if version == 3:
        lines.append(
            _hline(f"G{len(types):5d}" + "".join(f" {t}" for t in types), "SYS / # / OBS TYPES")
        )
    else:
        lines.append(_hline(f"{1:6d}{1:6d}", "WAVELENGTH FACT L1/2"))
        lines.append(
            _hline(f"{len(types):6d}" + "".join(f"{t:>6}" for t in types), "# / TYPES OF OBSERV")
        )
    lines.append(_hline(f"{obs.interval_s:10.3f}", "INTERVAL"))
    lines.append(
        _hline(f"{y:6d}{mo:6d}{d:6d}{h:6d}{mi:6d}{s:13.7f}{'GPS':>8}", "TIME OF FIRST OBS")
    )
    if version == 3:
        if "L1C" in types:
            lines.append(_hline(f"G L1C {0.0:8.5f}", "SYS / PHASE SHIFT"))
        lines.append(
            _hline(" C1C    0.000 C1P    0.000 C2C    0.000 C2P    0.000", "GLONASS COD/PHS/BIS")
        )
    lines.append(_hline("", "END OF HEADER"))
    return "".join(lines)


def obs_text(obs: ObsTable, version: int = 3) -> str:
    """The RINEX observation file of ``obs`` (``version`` 3: 3.04, 2: 2.11) as text."""
    if version not in (2, 3):
        raise ValueError(f"RINEX version must be 2 or 3, found {version}")
    with_phase = obs.phase_cycles is not None
    names = _OBS3 if version == 3 else _OBS2
    types = [t for t in names if with_phase or not t.startswith("L")]
    parts = [_obs_header(obs, version, types)]
    seen = np.isfinite(obs.code_m)
    for i, t in enumerate(obs.time_gpst_s):
        cols: list[int] = np.flatnonzero(seen[i]).tolist()
        y, mo, d, h, mi, s = gpst_to_calendar(float(t))
        if version == 3:
            parts.append(f"> {y:4d} {mo:02d} {d:02d} {h:02d} {mi:02d}{s:11.7f}  0{len(cols):3d}\n")
            for j in cols:
                parts.append(
                    f"G{int(obs.prn[j]):02d}"
                    + "".join(_obs_fields(obs, i, j, with_phase)).rstrip()
                    + "\n"
                )
            continue
        sats = [f"G{int(obs.prn[j]):02d}" for j in cols]
        head = f" {y % 100:02d} {mo:2d} {d:2d} {h:2d} {mi:2d}{s:11.7f}  0{len(cols):3d}"
        parts.append(head + "".join(sats[:12]) + "\n")
        for k in range(12, len(sats), 12):
            parts.append(" " * 32 + "".join(sats[k : k + 12]) + "\n")
        for j in cols:
            fields = _obs_fields(obs, i, j, with_phase)
            for k in range(0, len(fields), 5):
                parts.append("".join(fields[k : k + 5]).rstrip() + "\n")
    return "".join(parts)


def write_obs(obs: ObsTable, path: Path, version: int = 3) -> Path:
    """Write ``obs`` as a RINEX observation file (atomically); returns ``path``."""
    write_text_atomic(path, obs_text(obs, version))
    return Path(path)


def _d19(value: float, exponent: str) -> str:
    text = f"{value: .12E}"
    mant, exp = text.split("E")
    return f"{mant}{exponent}{exp[0]}{abs(int(exp)):02d}"


def _nav_values(eph: GpsEphemerides, k: int) -> list[float]:
    """The 26 broadcast orbit values of record ``k`` in RINEX order (lines 1-7)."""
    week, toe_sow = divmod(float(eph.toe_gpst_s[k]), _WEEK_S)  # the week that goes with toe
    iode = float(eph.iode[k])
    return [
        iode, float(eph.crs[k]), float(eph.delta_n[k]), float(eph.m0[k]),
        float(eph.cuc[k]), float(eph.e[k]), float(eph.cus[k]), float(eph.sqrt_a[k]),
        toe_sow, float(eph.cic[k]), float(eph.omega0[k]), float(eph.cis[k]),
        float(eph.i0[k]), float(eph.crc[k]), float(eph.omega[k]), float(eph.omega_dot[k]),
        float(eph.idot[k]), 0.0, week, 0.0,
        2.0, float(eph.health[k]), float(eph.tgd[k]), iode,
        max(0.0, toe_sow - 7200.0), float(eph.fit_interval_h[k]),
    ]  # fmt: skip


def nav_text(eph: GpsEphemerides, version: int = 3) -> str:
    """The GPS navigation file of ``eph`` (``version`` 3: 3.04, 2: 2.11) as text, records
    in time then PRN order."""
    if version not in (2, 3):
        raise ValueError(f"RINEX version must be 2 or 3, found {version}")
    exp = "E" if version == 3 else "D"
    order = np.lexsort((eph.prn, eph.toc_gpst_s))
    first = (
        gpst_to_calendar(float(eph.toc_gpst_s[order[0]])) if len(eph) else (1980, 1, 6, 0, 0, 0.0)
    )
    stamp = f"{first[0]:04d}{first[1]:02d}{first[2]:02d} {first[3]:02d}{first[4]:02d}00 GPS"
    lines = []
    if version == 3:
        lines.append(
            _hline(
                f"{3.04:9.2f}{'':11}{'N: GNSS NAV DATA':20}{'G: GPS':20}", "RINEX VERSION / TYPE"
            )
        )
    else:
        lines.append(_hline(f"{2.11:9.2f}{'':11}{'N: GPS NAV DATA':40}", "RINEX VERSION / TYPE"))
    lines.append(_hline(f"{'coopproc':20}{'coopproc':20}{stamp}", "PGM / RUN BY / DATE"))
    for tag, coeffs in (("A", eph.iono_alpha), ("B", eph.iono_beta)):
        if coeffs is None:
            continue
        if version == 3:
            body = f"GPS{tag} " + "".join(_iono12(c) for c in coeffs)
            lines.append(_hline(body, "IONOSPHERIC CORR"))
        else:
            label = "ION ALPHA" if tag == "A" else "ION BETA"
            lines.append(_hline("  " + "".join(_iono12(c, "D") for c in coeffs), label))
    lines.append(_hline("", "END OF HEADER"))
    for k in (int(i) for i in order):
        y, mo, d, h, mi, s = gpst_to_calendar(float(eph.toc_gpst_s[k]))
        clock = "".join(_d19(float(v), exp) for v in (eph.af0[k], eph.af1[k], eph.af2[k]))
        prn = int(eph.prn[k])
        if version == 3:
            lines.append(
                f"G{prn:02d} {y:4d} {mo:02d} {d:02d} {h:02d} {mi:02d} {round(s):02d}{clock}\n"
            )
            indent = "    "
        else:
            lines.append(f"{prn:2d} {y % 100:02d} {mo:2d} {d:2d} {h:2d} {mi:2d}{s:5.1f}{clock}\n")
            indent = "   "
        values = _nav_values(eph, k)
        for row in range(0, len(values), 4):
            chunk = values[row : row + 4]
            lines.append(indent + "".join(_d19(v, exp) for v in chunk) + "\n")
    return "".join(lines)


def _iono12(value: float, exponent: str = "E") -> str:
    """A Klobuchar coefficient as RINEX D12.4."""
    text = f"{value: .4E}"
    mant, exp = text.split("E")
    return f"{mant}{exponent}{exp[0]}{abs(int(exp)):02d}".rjust(12)


def write_nav(eph: GpsEphemerides, path: Path, version: int = 3) -> Path:
    """Write ``eph`` as a RINEX GPS navigation file (atomically); returns ``path``."""
    write_text_atomic(path, nav_text(eph, version))
    return Path(path)
