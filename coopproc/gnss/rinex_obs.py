"""RINEX 2.x and 3.x observation files -> GnssObservations (all systems kept as read).

Own fixed-column parser (docs/methods-gnss.md says why):

- RINEX 2: header ``# / TYPES OF OBSERV`` (continued lines), epochs
  ``1X,I2,4(1X,I2),F11.7,2X,I1,I3`` + 12 satellites per line (``A1,I2``, continued on
  lines indented by 32), then per satellite ``5(F14.3,I1,I1)`` per line;
- RINEX 3: header ``SYS / # / OBS TYPES`` per system, epochs
  ``'>',1X,I4,4(1X,I2),F11.7,2X,I1,I3``, then one line per satellite ``A1,I2,
  m(F14.3,I1,I1)``;
- event flags 2-5 (header records in the body) and 6 (cycle slips) are skipped; 0 and 1
  are observations. Epoch times are the receiver's (GPST).

A malformed epoch or number, or a file cut short in an epoch, raises a one-line
:class:`~coopproc.errors.InputError` naming file and line.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from coopproc.errors import InputError
from coopproc.model import FloatArray

__all__ = ["GnssObservations", "read_obs"]

IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class GnssObservations:
    """Observations of one receiver as a long table (one row per epoch and satellite).

    ``epoch_gpst_s`` (m,) receiver epoch times, GPST seconds since the GPS epoch;
    ``epoch_index`` (k,) each row's epoch; ``system`` (k,) one letter (G R E C J S I);
    ``prn`` (k,); ``values`` observation code as written in the file (RINEX 2 ``C1``,
    ``P2`` ...; RINEX 3 ``C1C``, ``D1C``, ``S1C`` ...) -> (k,) values, NaN where blank;
    ``types`` the codes per system; ``line`` (k,) the file line of each row (for errors);
    ``approx_position_ecef_m`` the header's APPROX POSITION XYZ (None when absent or zero);
    ``epoch_line`` (m,) the file line of each epoch (None for tables not read from a file).
    """

    epoch_gpst_s: FloatArray
    epoch_index: IntArray
    system: NDArray[np.str_]
    prn: IntArray
    values: dict[str, FloatArray]
    types: dict[str, tuple[str, ...]]
    line: IntArray
    version: float
    marker: str = ""
    approx_position_ecef_m: FloatArray | None = None
    interval_s: float | None = None
    source: str = ""
    leap_seconds: int | None = field(default=None)
    epoch_line: IntArray | None = None

    def code(self, candidates: tuple[str, ...]) -> FloatArray:
        """The first of ``candidates`` present per row (NaN where none is)."""
        out = np.full(self.prn.shape[0], np.nan)
        for name in candidates:
            column = self.values.get(name)
            if column is not None:
                out = np.where(np.isnan(out), column, out)
        return out


class _Header:
    def __init__(self) -> None:
        self.version = 0.0
        self.types: dict[str, list[str]] = {}
        self.marker = ""
        self.approx: FloatArray | None = None
        self.interval: float | None = None
        self.leap: int | None = None


def _float(text: str, path: Path, line: int, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InputError(path, f"{what} {text.strip()!r} is not a number", line=line) from None


def _read_header(lines: list[str], path: Path) -> tuple[_Header, int]:
    if not lines or "RINEX VERSION / TYPE" not in lines[0][60:]:
        raise InputError(path, "not a RINEX file: no 'RINEX VERSION / TYPE' line", line=1)
    head = _Header()
    head.version = _float(lines[0][:9], path, 1, "RINEX version")
    if lines[0][20:21].upper() != "O":
        raise InputError(
            path,
            f"RINEX file type {lines[0][20:40].strip()!r}; expected observation data ('O')",
            line=1,
        )
    default_sys = (lines[0][40:41].strip() or "G").upper()
    pending_v2: list[str] = []
    n_v2 = 0
    last_sys = ""
    for i, text in enumerate(lines[1:], start=2):
        label = text[60:].strip()
        if label == "END OF HEADER":
            if head.version < 3:
                systems = "GRESJ" if default_sys == "M" else default_sys
                for s in systems:
                    head.types[s] = pending_v2
            if not head.types or not any(head.types.values()):
                raise InputError(path, "no observation types in the header", line=i)
            return head, i
        if label == "MARKER NAME":
            head.marker = text[:60].strip()
        elif label == "APPROX POSITION XYZ":
            xyz = np.array(
                [_float(text[14 * k : 14 * k + 14], path, i, "position") for k in range(3)]
            )
            head.approx = xyz if np.any(xyz) else None
        elif label == "INTERVAL":
            head.interval = _float(text[:10], path, i, "interval")
        elif label == "LEAP SECONDS":
            head.leap = int(_float(text[:6], path, i, "leap seconds"))
        elif label == "# / TYPES OF OBSERV":
            if text[:6].strip():
                n_v2 = int(_float(text[:6], path, i, "number of types"))
            pending_v2 += text[6:60].split()
            if len(pending_v2) > n_v2:
                raise InputError(
                    path, f"{len(pending_v2)} observation types, header says {n_v2}", line=i
                )
        elif label == "SYS / # / OBS TYPES":
            if text[0].strip():
                last_sys = text[0].upper()
                head.types[last_sys] = []
            elif not last_sys:
                raise InputError(path, "SYS / # / OBS TYPES continuation without a system", line=i)
            head.types[last_sys] += text[7:60].split()
    raise InputError(path, "truncated header: no 'END OF HEADER' line", line=len(lines))


def _epoch_time(text: str, v3: bool, path: Path, line: int) -> float:
    parts = (text[1:29] if v3 else text[:26]).split()
    try:
        year, month, day, hour, minute = (int(p) for p in parts[:5])
        second = float(parts[5])
    except (ValueError, IndexError):
        raise InputError(
            path,
            f"epoch {text[:32].strip()!r}; expected "
            + (
                "'> yyyy mm dd hh mm ss.sssssss  flag nsat'"
                if v3
                else "'yy mm dd hh mm ss.sssssss  flag nsat'"
            ),
            line=line,
        ) from None
    if year < 100:
        year += 1900 if year >= 80 else 2000
    try:
        day0 = np.datetime64(f"{year:04d}-{month:02d}-{day:02d}", "D")
    except ValueError:
        raise InputError(
            path, f"epoch date {year}-{month}-{day} does not exist", line=line
        ) from None
    days = float((day0 - np.datetime64("1980-01-06", "D")).astype(np.int64))
    return days * 86400.0 + hour * 3600.0 + minute * 60.0 + second


def _values(text: str, start: int, count: int, path: Path, line: int) -> list[float]:
    out = []
    for k in range(count):
        field_text = text[start + 16 * k : start + 16 * k + 14]
        s = field_text.strip()
        if not s:
            out.append(np.nan)
            continue
        try:
            out.append(float(s))
        except ValueError:
            raise InputError(
                path, f"observation {k + 1} {s!r} is not a number (expected F14.3)", line=line
            ) from None
    return out


def read_obs(path: str | Path) -> GnssObservations:
    """The observations of one RINEX 2/3 observation file; raises InputError."""
    p = Path(path)
    try:
        lines = p.read_text(encoding="ascii", errors="replace").splitlines()
    except OSError as err:
        raise InputError(p, f"cannot read ({err.strerror or type(err).__name__})") from err
    head, i = _read_header(lines, p)
    v3 = head.version >= 3
    epochs: list[float] = []
    epoch_lines: list[int] = []
    rows: list[tuple[int, str, int, int]] = []  # epoch, system, prn, line
    data: dict[str, list[list[float]]] = {s: [] for s in head.types}
    row_sys: list[str] = []
    total = len(lines)
    while i < total:
        text = lines[i]
        number = i + 1
        if not text.strip():
            i += 1
            continue
        if v3 and not text.startswith(">"):
            raise InputError(
                p, f"expected an epoch line starting with '>', found {text[:20]!r}", line=number
            )
        flag_text = text[31:32] if v3 else text[28:29]
        count_text = text[32:35] if v3 else text[29:32]
        try:
            flag = int(flag_text or "0")
            n_sat = int(count_text)
        except ValueError:
            raise InputError(
                p,
                f"epoch line {text[:35].strip()!r}: flag and satellite count not numbers",
                line=number,
            ) from None
        if flag > 1:  # header records (2-5) or cycle slips (6): skip the n lines
            i += 1 + n_sat
            continue
        t = _epoch_time(text, v3, p, number)
        sats: list[str] = []
        if v3:
            i += 1
        else:
            sat_text = text[32:68]
            i += 1
            while len(sats) + len(sat_text) // 3 < n_sat and i < total:
                sats += [sat_text[3 * k : 3 * k + 3] for k in range(len(sat_text) // 3)]
                sat_text = lines[i][32:68]
                i += 1
            sats += [sat_text[3 * k : 3 * k + 3] for k in range(n_sat - len(sats))]
        epoch = len(epochs)
        epochs.append(t)
        epoch_lines.append(number)
        for s in range(n_sat):
            if v3:
                if i >= total:
                    raise InputError(
                        p, f"truncated: epoch has {s} of {n_sat} satellites", line=number
                    )
                text = lines[i]
                sat = text[:3]
                start = i
                i += 1
            else:
                sat = sats[s]
                start = i
            sys_char = (sat[0].strip() or "G").upper()
            try:
                prn = int(sat[1:3])
            except ValueError:
                raise InputError(
                    p, f"satellite {sat!r}; expected e.g. 'G05'", line=start + 1
                ) from None
            types = head.types.get(sys_char)
            if types is None:
                raise InputError(
                    p, f"satellite {sat!r} of a system without observation types", line=start + 1
                )
            if v3:
                vals = _values(text, 3, len(types), p, start + 1)
            else:
                n_lines = (len(types) + 4) // 5
                if i + n_lines > total:
                    raise InputError(
                        p, f"truncated: epoch has {s} of {n_sat} satellites complete", line=number
                    )
                vals = []
                for k in range(n_lines):
                    vals += _values(lines[i + k], 0, min(5, len(types) - 5 * k), p, i + k + 1)
                i += n_lines
            rows.append((epoch, sys_char, prn, start + 1))
            row_sys.append(sys_char)
            data[sys_char].append(vals)
    return replace(
        _assemble(p, head, epochs, rows, data),
        epoch_line=np.array(epoch_lines, dtype=np.int64),
    )


def _assemble(
    p: Path,
    head: _Header,
    epochs: list[float],
    rows: list[tuple[int, str, int, int]],
    data: dict[str, list[list[float]]],
) -> GnssObservations:
    k = len(rows)
    if k == 0:
        raise InputError(p, "no observation epochs after the header")
    system = np.array([r[1] for r in rows], dtype="<U1")
    codes = sorted({c for types in head.types.values() for c in types})
    values = {c: np.full(k, np.nan) for c in codes}
    for sys_char, types in head.types.items():
        sel = np.flatnonzero(system == sys_char)
        if sel.size == 0:
            continue
        block = np.array(data[sys_char], dtype=np.float64).reshape(sel.size, len(types))
        for j, c in enumerate(types):
            values[c][sel] = block[:, j]
    return GnssObservations(
        epoch_gpst_s=np.array(epochs, dtype=np.float64),
        epoch_index=np.array([r[0] for r in rows], dtype=np.int64),
        system=system,
        prn=np.array([r[2] for r in rows], dtype=np.int64),
        values=values,
        types={s: tuple(t) for s, t in head.types.items()},
        line=np.array([r[3] for r in rows], dtype=np.int64),
        version=head.version,
        marker=head.marker,
        approx_position_ecef_m=head.approx,
        interval_s=head.interval,
        source=str(p),
        leap_seconds=head.leap,
    )
