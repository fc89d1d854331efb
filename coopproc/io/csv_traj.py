"""nav_<ID>.csv / ref_<ID>.csv (plain or .csv.gz): read and write (DATA.md).

One row per epoch, a header line, ``#`` comment lines allowed before it; positions in
one of three forms (``east,north,up`` | ``lat,lon,height`` | ``x,y,z``); optional
``sigma_*``, ``vel_*``, ``heading`` and (an extension, written for references)
``quality``. A column that is none of these is an error naming the nearest known column,
so a misspelled optional column is not silently ignored.
"""

from __future__ import annotations

import gzip
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.configtools import nearest
from coopproc.errors import InputError
from coopproc.io._common import (
    PARSE_ERRORS,
    InputProblems,
    Locator,
    RawTrajectory,
    check_trajectory_times,
    file_lines,
    missing_column,
    numeric_column,
    one_line,
    parser_error,
)
from coopproc.io.outdir import write_csv
from coopproc.model import Trajectory

__all__ = [
    "NAV_HEADER",
    "POSITION_FORMS",
    "TRAJECTORY_COLUMNS",
    "read_csv_table",
    "read_traj_csv",
    "trajectory_from_frame",
    "write_traj_csv",
]

#: The three position forms, in order of preference when a file has several.
POSITION_FORMS: dict[str, tuple[str, str, str]] = {
    "enu": ("east", "north", "up"),
    "llh": ("lat", "lon", "height"),
    "ecef": ("x", "y", "z"),
}
_SIGMA = ("sigma_east", "sigma_north", "sigma_up")
_VEL = ("vel_east", "vel_north", "vel_up")
#: Every column a nav/ref table may hold.
TRAJECTORY_COLUMNS: tuple[str, ...] = (
    "time",
    *POSITION_FORMS["enu"],
    *POSITION_FORMS["llh"],
    *POSITION_FORMS["ecef"],
    *_SIGMA,
    *_VEL,
    "heading",
    "quality",
)

#: The header a nav/ref table starts with, for messages.
NAV_HEADER = "time,east,north,up (or lat,lon,height or x,y,z for the position)"


def _header_line(path: Path) -> tuple[int, str]:
    """1-based line number and text of the header (after ``#`` comments and blank lines)."""
    opener = gzip.open if path.name.endswith(".gz") else open
    with opener(path, "rt", encoding="utf-8") as fh:
        for number, text in enumerate(fh, start=1):
            stripped = text.strip()
            if stripped and not stripped.startswith("#"):
                return number, stripped
    raise InputError(path, "empty file; expected a header line and data rows")


_SEPARATORS = ((";", "';'"), ("\t", "tab"), ("|", "'|'"), (" ", "space"))


def _check_header(path: Path, number: int, text: str, known: Sequence[str], expected: str) -> None:
    """One clear error for a header that is not comma separated, or not a header at all."""
    if "," not in text:
        for sep, name in _SEPARATORS:
            if len([f for f in text.split(sep) if f.strip()]) >= 2:
                shown = text if len(text) <= 40 else text[:37] + "..."
                raise InputError(
                    path,
                    f"uses {name} as separator (header {shown!r}); coopproc expects ','",
                    line=number,
                )
    fields = [f.strip().strip('"') for f in text.split(",")]
    if not known or any(f in known for f in fields):
        return
    if any(_is_number(f) for f in fields):
        values = [one_line(f, 20) for f in fields if f]
        like = ", ".join(values[:3]) + (", ..." if len(values) > 3 else "")
        which = "first line" if number == 1 else "first line after the comments"
        raise InputError(
            path,
            f"{which} is not a header (found values like {like}); expected the header {expected}",
            line=number,
        )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_csv_table(
    path: Path, known: Sequence[str] = (), expected: str = ""
) -> tuple[pd.DataFrame, Locator]:
    """A comma-separated table with ``#`` comments before its header, and its row lines.

    ``known``: column names the header should hold (for the message of a file without a
    header, which names ``expected``, e.g. ``time,from,to,range``).
    """
    try:
        header, text = _header_line(path)
        _check_header(path, header, text, known, expected)
        frame = pd.read_csv(
            path,
            skiprows=header - 1,
            skipinitialspace=True,
            dtype={"from": str, "to": str},
            compression="infer",
            encoding="utf-8",
            engine="c",
            low_memory=False,
        )
    except InputError:
        raise
    except pd.errors.ParserError as err:
        raise parser_error(path, err, "the header's columns") from err
    except PARSE_ERRORS as err:
        raise InputError(
            path, f"cannot read as CSV ({type(err).__name__}: {one_line(err)})"
        ) from err
    frame.columns = [str(c).strip() for c in frame.columns]
    unnamed = [c for c in frame.columns if c.startswith("Unnamed:")]
    if unnamed:
        raise InputError(path, "a column has no name in the header", line=header)
    return frame, Locator(str(path), lines=file_lines(path, header + 1))


def trajectory_from_frame(frame: pd.DataFrame, platform: str, where: Locator) -> RawTrajectory:
    """Validate a nav/ref table and return its raw trajectory (all problems at once)."""
    columns = [str(c) for c in frame.columns]
    problems: list[InputError] = []
    for name in columns:
        if name not in TRAJECTORY_COLUMNS:
            problems.append(
                where.error(f"unknown column '{name}'{nearest(name, TRAJECTORY_COLUMNS)}")
            )
    if "time" not in columns:
        problems.append(missing_column("time", columns, where))
    form = next((f for f, cols in POSITION_FORMS.items() if set(cols) <= set(columns)), None)
    if form is None:
        partial = [c for f in POSITION_FORMS.values() for c in f if c in columns]
        found = f"found {', '.join(partial)}" if partial else "found none"
        problems.append(
            where.error(
                "missing position columns: expected east,north,up or lat,lon,height or "
                f"x,y,z; {found}"
            )
        )
    for group in (_SIGMA, _VEL):
        present = [c for c in group if c in columns]
        if present and len(present) != 3:
            missing = [c for c in group if c not in columns]
            problems.append(where.error(f"missing column(s) {', '.join(missing)}"))
    if problems:
        raise InputProblems(problems)
    if len(frame) == 0:
        raise where.error("no data rows; expected at least one epoch")
    assert form is not None
    time_s = numeric_column(frame, "time", where, problems)
    position = np.column_stack(
        [numeric_column(frame, c, where, problems) for c in POSITION_FORMS[form]]
    )

    def block(cols: tuple[str, ...]) -> np.ndarray | None:
        if cols[0] not in columns:
            return None
        return np.column_stack([numeric_column(frame, c, where, problems) for c in cols])

    sigma = block(_SIGMA)
    vel = block(_VEL)
    heading = numeric_column(frame, "heading", where, problems) if "heading" in columns else None
    quality = None
    if "quality" in columns:
        quality = numeric_column(frame, "quality", where, problems).astype(np.int64)
    if sigma is not None and np.any(sigma < 0):
        idx = np.flatnonzero(np.any(sigma < 0, axis=1))
        problems.append(where.error("negative sigma; expected >= 0 m", int(idx[0]), idx.size))
    if form == "llh":
        bad = (np.abs(position[:, 0]) > 90) | (np.abs(position[:, 1]) > 360)
        if bad.any():
            idx = np.flatnonzero(bad)
            problems.append(
                where.error(
                    f"lat/lon {position[idx[0], 0]}, {position[idx[0], 1]} out of range; "
                    "expected degrees",
                    int(idx[0]),
                    idx.size,
                )
            )
    if problems:
        raise InputProblems(problems)
    raw = RawTrajectory(
        platform=platform,
        time_s=time_s,
        position=position,
        form=form,  # type: ignore[arg-type]
        source=where.path,
        sigma_enu_m=sigma,
        vel_enu_mps=vel,
        heading_deg=heading,
        quality=quality,
    )
    return check_trajectory_times(raw, where)


def read_traj_csv(path: str | Path, platform: str) -> RawTrajectory:
    """Read a nav/ref CSV (or .csv.gz) of ``platform``; raises InputError."""
    p = Path(path)
    frame, where = read_csv_table(p, TRAJECTORY_COLUMNS, NAV_HEADER)
    return trajectory_from_frame(frame, platform, where)


def write_traj_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write a trajectory as a nav/ref CSV in ENU form (gzip when the name ends in .gz)."""
    return write_csv(traj.frame(), Path(path))
