"""session.toml ``[columns]`` and ``[files]`` encodings: how a session's CSVs are written.

```toml
[files]
encoding = "cp1252"            # every CSV of the session (default UTF-8; a BOM wins)
[files.encodings]              # per file, by its [files] key; wins over encoding
nav.A = "utf-16"

[columns]                      # coopproc name = the column's name in the files
time = "timestamp"
[columns.units]                # the files' units where they are not coopproc's
time = "ms"
[columns.ranges]               # only the ranges file (wins over [columns]); also nav, ref
range = "dist_mm"
[columns.ranges.units]
range = "mm"
```

Every key is checked (an unknown one names the nearest valid one); the result is a
:class:`CsvForms`, which gives each file its :class:`~coopproc.io.csv_forms.CsvForm`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from coopproc.configtools import check_keys, nearest
from coopproc.errors import ConfigError
from coopproc.io._common import ID_PATTERN
from coopproc.io.csv_forms import UNITS, CsvForm
from coopproc.io.csv_traj import TRAJECTORY_COLUMNS

__all__ = ["COLUMN_KINDS", "ENCODING_KEYS", "CsvForms", "parse_columns", "parse_encodings"]

#: The files ``[columns]`` applies to, with the columns and unit keys of each.
_RANGE_NAMES = ("time", "from", "to", "range", "sigma")
COLUMN_KINDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "nav": (TRAJECTORY_COLUMNS, ("time", "position", "velocity", "heading")),
    "ref": (TRAJECTORY_COLUMNS, ("time", "position", "velocity", "heading")),
    "ranges": (_RANGE_NAMES, ("time", "range")),
}
_ALL_NAMES = tuple(dict.fromkeys((*TRAJECTORY_COLUMNS, *_RANGE_NAMES)))
#: Keys of ``[files]`` this module reads (the rest are file names: session_toml.py).
ENCODING_KEYS = ("encoding", "encodings")
_COMMON_ENCODINGS = ("utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "latin-1", "cp1252")


@dataclass(frozen=True)
class CsvForms:
    """The CSV forms session.toml declares: encodings, column names, units."""

    encoding: str | None = None
    #: ``[files.encodings]``: ``ranges`` / ``nav.<ID>`` / ``ref.<ID>`` -> encoding.
    encodings: Mapping[str, str] = field(default_factory=dict)
    #: ``""`` (``[columns]``), ``nav``, ``ref``, ``ranges`` -> {coopproc name: file's name}.
    columns: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    #: Same keys -> {unit key: unit}.
    units: Mapping[str, Mapping[str, str]] = field(default_factory=dict)

    def form(self, key: str) -> CsvForm:
        """The form of the file of ``[files]`` key ``key`` (``ranges``, ``nav.A``, ...)."""
        kind = key.split(".", 1)[0]
        encoding, origin = self.encoding, "session.toml [files] encoding"
        if key in self.encodings:
            encoding, origin = self.encodings[key], f"session.toml [files.encodings] {key}"
        columns = {**self.columns.get("", {}), **self.columns.get(kind, {})}
        units = {**self.units.get("", {}), **self.units.get(kind, {})}
        return CsvForm(encoding, origin, columns, units)


def _encoding(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value:
        raise ConfigError(f'{where}: expected an encoding name, e.g. "cp1252"; found {value!r}')
    try:
        b"time".decode(value)
    except LookupError:
        raise ConfigError(
            f"{where}: {value!r} is not a text encoding{nearest(value, _COMMON_ENCODINGS)}; "
            f"expected e.g. {', '.join(_COMMON_ENCODINGS)}"
        ) from None
    return value


def parse_encodings(files: Mapping[str, Any], where: str) -> tuple[str | None, dict[str, str]]:
    """``[files] encoding`` and ``[files.encodings]`` (``where``: ``session.toml``)."""
    encoding = None
    if "encoding" in files:
        encoding = _encoding(files["encoding"], f"{where} [files] encoding")
    table = files.get("encodings", {})
    if not isinstance(table, Mapping):
        raise ConfigError(f'{where} [files] encodings: expected a table, e.g. nav.A = "utf-16"')
    check_keys(table, ("ranges", "nav", "ref"), f"{where} [files.encodings]")
    out: dict[str, str] = {}
    for key, value in table.items():
        if key == "ranges":
            out[key] = _encoding(value, f"{where} [files.encodings] ranges")
            continue
        if not isinstance(value, Mapping):
            raise ConfigError(f'{where} [files.encodings] {key}: expected {key}.<ID> = "utf-16"')
        for pid, name in value.items():
            if not ID_PATTERN.match(pid):
                raise ConfigError(f"{where} [files.encodings.{key}] {pid}: not a platform id")
            out[f"{key}.{pid}"] = _encoding(name, f"{where} [files.encodings] {key}.{pid}")
    return encoding, out


def _names(table: Mapping[str, Any], valid: tuple[str, ...], where: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for name, given in table.items():
        if name not in valid:
            raise ConfigError(f"{where}: unknown key '{name}'{nearest(name, valid)}")
        if not isinstance(given, str) or not given.strip():
            raise ConfigError(
                f"{where} {name}: expected the column's name in the file, found {given!r}"
            )
        out[name] = given.strip()
    return out


def _units(table: Any, valid: tuple[str, ...], where: str) -> dict[str, str]:
    if not isinstance(table, Mapping):
        raise ConfigError(f'{where}: expected a table, e.g. time = "ms"')
    check_keys(table, valid, where)
    out: dict[str, str] = {}
    for key, unit in table.items():
        choices = UNITS[key]
        if unit not in choices:
            raise ConfigError(
                f"{where} {key}: {unit!r}{nearest(str(unit), choices)}; "
                f"expected {' | '.join(choices)}"
            )
        out[key] = unit
    return out


def parse_columns(
    table: Any, where: str
) -> tuple[dict[str, dict[str, str]], dict[str, dict[str, str]]]:
    """``[columns]`` -> (columns, units), each keyed ``""``, ``nav``, ``ref``, ``ranges``."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where} [columns]: expected a table")
    sub = ("units", *COLUMN_KINDS)
    check_keys(table, (*_ALL_NAMES, *sub), f"{where} [columns]")
    top = {k: v for k, v in table.items() if k not in sub}
    columns = {"": _names(top, _ALL_NAMES, f"{where} [columns]")}
    units = {"": _units(table.get("units", {}), tuple(UNITS), f"{where} [columns.units]")}
    for kind, (names, unit_keys) in COLUMN_KINDS.items():
        own = table.get(kind, {})
        place = f"{where} [columns.{kind}]"
        if not isinstance(own, Mapping):
            raise ConfigError(f'{place}: expected a table, e.g. time = "stamp"')
        check_keys(own, (*names, "units"), place)
        columns[kind] = _names({k: v for k, v in own.items() if k != "units"}, names, place)
        units[kind] = _units(own.get("units", {}), unit_keys, f"{where} [columns.{kind}.units]")
        merged = {**columns[""], **columns[kind]}
        merged = {k: v for k, v in merged.items() if k in names}
        seen: dict[str, str] = {}
        for name, given in merged.items():
            if given in seen:
                raise ConfigError(
                    f"{where} [columns]: {seen[given]} and {name} both name column "
                    f"'{given}' of the {kind} files; expected one column per name"
                )
            seen[given] = name
    return columns, units
