"""TUM trajectory files (``nav_<ID>.tum`` / ``ref_<ID>.tum``): read and write.

``timestamp tx ty tz qx qy qz qw`` per line, space separated, ``#`` comments; ``tx ty tz``
are east, north, up (DATA.md). Only positions are used: the orientation quaternion's
body axes are not specified by the format, so no heading is derived from it, and the
writer writes the identity quaternion.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.io._common import (
    PARSE_ERRORS,
    InputProblems,
    Locator,
    RawTrajectory,
    check_trajectory_times,
    file_lines,
    numeric_column,
    one_line,
    parser_error,
)
from coopproc.model import Trajectory

__all__ = ["read_tum", "write_tum"]

_COLUMNS = ("timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw")


def read_tum(path: str | Path, platform: str) -> RawTrajectory:
    """Read a TUM trajectory of ``platform``; raises InputError."""
    p = Path(path)
    try:
        frame = pd.read_csv(
            p,
            sep=r"\s+",
            comment="#",
            header=None,
            names=list(_COLUMNS),
            dtype=str,
            engine="c",
            compression="infer",
            encoding="utf-8",
        )
    except pd.errors.ParserError as err:
        raise parser_error(p, err, "timestamp tx ty tz qx qy qz qw") from err
    except pd.errors.EmptyDataError as err:
        raise InputError(p, "empty file; expected lines 'timestamp tx ty tz qx qy qz qw'") from err
    except PARSE_ERRORS as err:
        raise InputError(p, f"cannot read as TUM ({type(err).__name__}: {one_line(err)})") from err
    where = Locator(str(p), lines=_tum_lines(p))
    if len(frame) == 0:
        raise where.error("no data rows; expected lines 'timestamp tx ty tz qx qy qz qw'")
    short = frame["qw"].isna().to_numpy()
    if short.any():
        idx = np.flatnonzero(short)
        raise where.error(
            "too few fields; expected 8: timestamp tx ty tz qx qy qz qw", int(idx[0]), idx.size
        )
    problems: list[InputError] = []
    time_s = numeric_column(frame, "timestamp", where, problems)
    position = np.column_stack([numeric_column(frame, c, where, problems) for c in _COLUMNS[1:4]])
    for c in _COLUMNS[4:]:
        numeric_column(frame, c, where, problems)
    if problems:
        raise InputProblems(problems)
    raw = RawTrajectory(
        platform=platform, time_s=time_s, position=position, form="enu", source=str(p)
    )
    return check_trajectory_times(raw, where)


def _tum_lines(path: Path) -> Callable[[int], int]:
    """Row -> line map that skips ``#`` comment lines too."""
    base = file_lines(path, 1)
    cache: list[int] = []

    def line_of(row: int) -> int:
        if not cache:
            try:
                with open(path, encoding="utf-8", errors="replace") as fh:
                    for number, text in enumerate(fh, start=1):
                        s = text.strip()
                        if s and not s.startswith("#"):
                            cache.append(number)
            except PARSE_ERRORS:
                return base(row)
        return cache[row] if row < len(cache) else base(row)

    return line_of


def write_tum(traj: Trajectory, path: str | Path) -> Path:
    """Write a trajectory's positions as a TUM file (identity orientation)."""
    p = Path(path)
    n = len(traj)
    data = np.column_stack([traj.time_s, traj.enu_m, np.zeros((n, 3)), np.ones((n, 1))])
    with open(p, "w", encoding="utf-8") as fh:
        fh.write("# timestamp tx ty tz qx qy qz qw  (tx ty tz = east north up, metres)\n")
        np.savetxt(fh, data, fmt="%.6f")
    return p
