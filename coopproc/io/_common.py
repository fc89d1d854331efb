"""What every reader shares: the raw trajectory, row locations, problem lists, checks.

Readers turn a file into a :class:`RawTrajectory` (positions still in the file's form and
times in the file's time kind) or a range DataFrame; ``assemble`` then picks the origin,
converts to ENU and to the session time base. Row-level checks here report every kind
of problem of a file at once (:class:`InputProblems`), each as one line with the first
offending line and the count of others.
"""

from __future__ import annotations

import difflib
import gzip
import re
import struct
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.errors import CoopprocError, InputError
from coopproc.model import FloatArray

__all__ = [
    "ID_PATTERN",
    "PARSE_ERRORS",
    "InputProblems",
    "Locator",
    "RawTrajectory",
    "check_trajectory_times",
    "expand",
    "flat",
    "missing_column",
    "numeric_column",
    "one_line",
    "parser_error",
]

#: Platform ids: letters, digits, ``_`` and ``-`` (DATA.md "Words").
ID_PATTERN = re.compile(r"\A[A-Za-z0-9_-]+\Z")

#: Exceptions third-party parsers raise on bad bytes; readers turn them into InputError.
PARSE_ERRORS: tuple[type[BaseException], ...] = (
    ValueError,
    TypeError,
    KeyError,
    IndexError,
    OverflowError,
    UnicodeError,
    EOFError,
    OSError,
    zlib.error,
    struct.error,
    gzip.BadGzipFile,
    pd.errors.ParserError,
    pd.errors.EmptyDataError,
)

PositionForm = Literal["enu", "llh", "ecef"]
TimeKind = Literal["session", "gpst"]


class InputProblems(InputError):
    """Several problems of one input; renders as the first, carries all in ``errors``."""

    def __init__(self, errors: Sequence[InputError]) -> None:
        errors = _one_per_short_line(errors)
        first = errors[0]
        self.errors: tuple[InputError, ...] = tuple(errors)
        more = len(errors) - 1
        suffix = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
        super().__init__(first.path, first.problem + suffix, line=first.line, record=first.record)


_EMPTY_CELL = re.compile(r"\Acolumn '(?P<name>[^']*)': empty or NaN, expected a number\Z")


def _one_per_short_line(errors: Sequence[InputError]) -> list[InputError]:
    """One message for the empty cells of one line (a truncated or short line), not one
    per column: two or more "column 'x': empty or NaN" errors at the same line that
    name that line alone (no "and N more rows") become one, naming the columns."""
    found: dict[tuple[str | None, int], list[int]] = {}
    for k, err in enumerate(errors):
        if err.line is not None and _EMPTY_CELL.match(err.problem):
            found.setdefault((err.path, err.line), []).append(k)
    merged = {ks[0]: ks for ks in found.values() if len(ks) > 1}
    if not merged:
        return list(errors)
    dropped = {k for ks in merged.values() for k in ks[1:]}
    out = []
    for k, err in enumerate(errors):
        if k in dropped:
            continue
        if k in merged:
            names = [_EMPTY_CELL.match(errors[j].problem)["name"] for j in merged[k]]  # type: ignore[index]
            shown = ", ".join(names[:6]) + (", ..." if len(names) > 6 else "")
            err = InputError(
                err.path,
                f"{len(names)} empty cells ({shown}): a truncated or short line; expected a "
                "number in every column",
                line=err.line,
            )
        out.append(err)
    return out


def one_line(text: object, limit: int = 160) -> str:
    """``text`` on one line (whitespace collapsed), cut to ``limit`` characters."""
    flat = " ".join(str(text).split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


_PANDAS_FIELDS = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def parser_error(path: str | Path, err: BaseException, layout: str) -> InputError:
    """An InputError for a CSV/whitespace table that does not parse (pandas ParserError).

    ``layout`` says what a row should hold, e.g. ``"8 fields: timestamp tx ty ..."``.
    """
    m = _PANDAS_FIELDS.search(str(err))
    if m:
        expected, line, saw = m.groups()
        return InputError(
            path, f"malformed row: {saw} fields, expected {expected} ({layout})", line=int(line)
        )
    return InputError(path, f"malformed row: {one_line(err)}; expected {layout}")


def flat(err: CoopprocError) -> CoopprocError:
    """``err`` itself if its message is one line, else a copy whose message is."""
    if "\n" not in str(err) and "\r" not in str(err):
        return err
    if isinstance(err, InputError):
        record = None if err.record is None else one_line(err.record, 120)
        path = None if err.path is None else one_line(err.path, 300)
        return InputError(path, one_line(err.problem, 300), line=err.line, record=record)
    return type(err)(one_line(str(err), 300))


def expand(err: CoopprocError) -> list[str]:
    """Every one-line message an error stands for."""
    if isinstance(err, InputProblems):
        return [str(flat(e)) for e in err.errors]
    return [str(flat(err))]


@dataclass
class Locator:
    """Where row ``i`` of a table came from: a file line (CSV) or a record (MCAP)."""

    path: str
    #: File line of each row (1-based), or None to name records instead.
    lines: Callable[[int], int] | None = None
    #: Name of row ``i`` when there are no lines (e.g. ``message 12 on /A/nav``).
    record: Callable[[int], str] | None = None

    def error(self, message: str, row: int | None = None, count: int = 1) -> InputError:
        """An InputError at ``row`` (0-based), mentioning ``count - 1`` other rows."""
        message = one_line(message, 300)
        if count > 1:
            message += f" (and {count - 1} more row{'s' if count > 2 else ''})"
        if row is None:
            return InputError(self.path, message)
        if self.lines is not None:
            return InputError(self.path, message, line=self.lines(row))
        if self.record is not None:
            return InputError(self.path, message, record=one_line(self.record(row), 120))
        return InputError(self.path, message, record=f"row {row + 1}")


def numeric_column(
    frame: pd.DataFrame,
    name: str,
    where: Locator,
    problems: list[InputError],
    *,
    allow_empty: bool = False,
) -> FloatArray:
    """Column ``name`` as float64; non-numbers and (unless allowed) empty/NaN/inf reported."""
    raw = frame[name]
    if pd.api.types.is_float_dtype(raw.dtype) or pd.api.types.is_integer_dtype(raw.dtype):
        values = raw.to_numpy(dtype=np.float64, na_value=np.nan)
    else:
        values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=np.float64, na_value=np.nan)
        bad = np.isnan(values) & raw.notna().to_numpy()
        if bad.any():
            idx = np.flatnonzero(bad)
            found = str(raw.iloc[idx[0]])[:40]
            problems.append(
                where.error(
                    f"column '{name}': found {found!r}, expected a number", int(idx[0]), idx.size
                )
            )
            values = values.copy()
            values[bad] = 0.0
    missing = np.isnan(values)
    if not allow_empty and missing.any():
        idx = np.flatnonzero(missing)
        problems.append(
            where.error(f"column '{name}': empty or NaN, expected a number", int(idx[0]), idx.size)
        )
    infinite = np.isinf(values)
    if infinite.any():
        idx = np.flatnonzero(infinite)
        problems.append(
            where.error(
                f"column '{name}': found {values[idx[0]]}, expected a finite number",
                int(idx[0]),
                idx.size,
            )
        )
    return values


def missing_column(name: str, present: Sequence[str], where: Locator) -> InputError:
    """'missing column X', naming a present column that looks like a misspelling of it."""
    close = difflib.get_close_matches(name, [str(c) for c in present], n=1, cutoff=0.6)
    if close:
        hint = f"; found '{close[0]}' (misspelled?)"
    else:
        hint = f"; found columns {', '.join(str(c) for c in present)[:120] or 'none'}"
    return where.error(f"missing column '{name}'{hint}")


@dataclass
class RawTrajectory:
    """One trajectory as read: positions in the file's form, times in the file's kind."""

    platform: str
    time_s: FloatArray
    #: (n, 3) positions: east/north/up m, lat/lon deg + height m, or ECEF x/y/z m.
    position: FloatArray
    form: PositionForm
    source: str
    #: ``session``: already in the session time base; ``gpst``: GPST s since the GPS epoch.
    time_kind: TimeKind = "session"
    sigma_enu_m: FloatArray | None = None
    #: (n, 3, 3) ECEF covariance (RTKLIB ECEF form); rotated to ENU sigmas on assembly.
    cov_ecef_m2: FloatArray | None = None
    vel_enu_mps: FloatArray | None = None
    heading_deg: FloatArray | None = None
    quality: NDArray[np.int64] | None = None
    #: The GPS week of the first epoch (files that carry absolute GPST times).
    gps_week: int | None = None
    notes: list[str] = field(default_factory=list)
    #: Where the rows came from (file lines or records) and the input row of each row
    #: (rows are sorted and deduplicated on reading), for messages about single rows.
    where: Locator | None = None
    rows: NDArray[np.int64] | None = None

    def error(self, message: str, row: int | None = None, count: int = 1) -> InputError:
        """An InputError at row ``row`` of this trajectory, located at its input row."""
        if row is not None and self.rows is not None:
            row = int(self.rows[row])
        if self.where is None:
            return Locator(self.source).error(message, row, count)
        return self.where.error(message, row, count)

    def take(self, index: NDArray[np.intp]) -> RawTrajectory:
        """The rows ``index`` (a new object)."""

        def sub(a: NDArray | None) -> NDArray | None:  # type: ignore[type-arg]
            return None if a is None else a[index]

        return RawTrajectory(
            platform=self.platform,
            time_s=self.time_s[index],
            position=self.position[index],
            form=self.form,
            source=self.source,
            time_kind=self.time_kind,
            sigma_enu_m=sub(self.sigma_enu_m),
            cov_ecef_m2=sub(self.cov_ecef_m2),
            vel_enu_mps=sub(self.vel_enu_mps),
            heading_deg=sub(self.heading_deg),
            quality=sub(self.quality),
            gps_week=self.gps_week,
            notes=list(self.notes),
            where=self.where,
            rows=sub(self.rows),
        )


def check_trajectory_times(raw: RawTrajectory, where: Locator) -> RawTrajectory:
    """Sort unsorted rows (stable, noted); drop exact duplicate epochs (noted).

    Two rows with the same time and different positions are an error: the file does not
    say which one is right.
    """
    t = raw.time_s
    if t.size == 0:
        raise where.error("no data rows; expected at least one epoch")
    out = raw
    if np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        n_back = int(np.count_nonzero(np.diff(t) < 0))
        out = out.take(order)
        out.notes.append(
            f"{where.path}: times not in order ({n_back} step(s) back); rows sorted by time"
        )
    else:
        order = np.arange(t.size)
    same = np.flatnonzero(np.diff(out.time_s) == 0)
    if same.size:
        equal = np.all(out.position[same] == out.position[same + 1], axis=1)
        if not equal.all():
            first = int(same[~equal][0])
            raise where.error(
                f"time {float(out.time_s[first + 1])!r} appears twice with different positions; "
                "expected strictly increasing times",
                int(order[first + 1]),
                int(np.count_nonzero(~equal)),
            )
        keep = np.ones(out.time_s.size, dtype=bool)
        keep[same + 1] = False
        out = out.take(np.flatnonzero(keep))
        out.notes.append(f"{where.path}: {same.size} duplicated epoch(s) dropped")
        order = order[keep]
    out.where = where
    out.rows = np.asarray(order, dtype=np.int64)
    return out


def file_lines(path: Path, first_data_line: int) -> Callable[[int], int]:
    """Map data row index -> 1-based file line, skipping blank lines (read on demand)."""
    cache: list[int] = []

    def line_of(row: int) -> int:
        if not cache:
            opener = gzip.open if path.name.endswith(".gz") else open
            try:
                with opener(path, "rt", encoding="utf-8", errors="replace") as fh:
                    for number, text in enumerate(fh, start=1):
                        if number >= first_data_line and text.strip():
                            cache.append(number)
            except PARSE_ERRORS:
                return first_data_line + row
        return cache[row] if row < len(cache) else first_data_line + row

    return line_of
