"""nav_<ID>.csv / ref_<ID>.csv (plain or .csv.gz): read and write (DATA.md).

One row per epoch, a header line, ``#`` comment lines allowed before it; positions in
one of three forms (``east,north,up`` | ``lat,lon,height`` | ``x,y,z``); optional
``sigma_*``, ``vel_*``, ``heading`` and (an extension, written for references)
``quality``. Any other column is ignored with a note, except one that looks like a
misspelling of a known column the file lacks (an error naming it), so a misspelled
optional column is not silently lost. Encodings, delimiters, session.toml ``[columns]``
names and units: :mod:`coopproc.io.csv_forms`.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.configtools import nearest
from coopproc.errors import InputError
from coopproc.io._common import (
    InputProblems,
    Locator,
    RawTrajectory,
    check_trajectory_times,
    missing_column,
    numeric_column,
)
from coopproc.io.csv_forms import CsvForm, read_table
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

#: An extra column this close (difflib ratio) to a known column the file lacks is taken
#: for a misspelling of it (an error); any other extra column is ignored with a note.
_MISSPELLED = 0.8

#: The header a nav/ref table starts with, for messages.
NAV_HEADER = "time,east,north,up (or lat,lon,height or x,y,z for the position)"


def read_csv_table(
    path: Path, known: Sequence[str] = (), expected: str = "", form: CsvForm | None = None
) -> tuple[pd.DataFrame, Locator]:
    """A table with ``#`` comments before its header, and its row lines.

    Encoding, delimiter and session.toml ``[columns]`` as :func:`csv_forms.read_table`
    reads them (its notes are dropped here; the readers below keep them).
    """
    table = read_table(path, known, expected, form, text_columns=("from", "to"))
    return table.frame, table.where


def trajectory_from_frame(frame: pd.DataFrame, platform: str, where: Locator) -> RawTrajectory:
    """Validate a nav/ref table and return its raw trajectory (all problems at once)."""
    columns = [str(c) for c in frame.columns]
    problems: list[InputError] = []
    ignored = []
    for name in columns:
        if name in TRAJECTORY_COLUMNS:
            continue
        absent = [c for c in TRAJECTORY_COLUMNS if c not in columns]
        if difflib.get_close_matches(name, absent, n=1, cutoff=_MISSPELLED):
            # A misspelled column would be lost silently: an error, not an ignored column.
            problems.append(where.error(f"unknown column '{name}'{nearest(name, absent)}"))
        else:
            ignored.append(name)
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
    if ignored:
        shown = ", ".join(f"'{c}'" for c in ignored[:8]) + (", ..." if len(ignored) > 8 else "")
        raw.notes.append(f"{where.path}: column(s) {shown} ignored (not nav/ref columns)")
    return check_trajectory_times(raw, where)


def read_traj_csv(path: str | Path, platform: str, form: CsvForm | None = None) -> RawTrajectory:
    """Read a nav/ref CSV (or .csv.gz) of ``platform``; raises InputError.

    ``form``: encoding, column names and units other than the defaults (session.toml).
    """
    table = read_table(Path(path), TRAJECTORY_COLUMNS, NAV_HEADER, form, required=("time",))
    raw = trajectory_from_frame(table.frame, platform, table.where)
    raw.notes[:0] = table.notes
    return raw


def write_traj_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write a trajectory as a nav/ref CSV in ENU form (gzip when the name ends in .gz)."""
    return write_csv(traj.frame(), Path(path))
