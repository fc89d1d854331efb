"""``injected.csv``: what ``coopproc inject`` added to a session (docs/inject.md).

One row per affected range, in the session's time base:

- ``time``, ``pair``: the range's time and pair;
- ``kind``: ``nlos``, ``gross`` or ``outage`` (the range was removed);
- ``error``: metres added to the observed range; empty for ``outage``;
- ``event``: the event id, ``nlos1``, ``gross1``, ``outage1``, ...;
- ``start``, ``end``: the event's window as asked for (a gross error: its time twice);
- ``mean``, ``sd``: NLOS: the N(mean, sd^2) the errors were drawn from; gross: ``mean``
  is the size; empty otherwise.

The file sits in the new session directory; the session readers ignore it, and
``coopproc run`` scores the methods against it (``injected_scores.csv``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import InputError
from coopproc.io.outdir import write_csv

__all__ = [
    "INJECTED_COLUMNS",
    "INJECTED_FILE",
    "INJECTED_KINDS",
    "read_injected",
    "session_injected",
    "write_injected",
]

#: The file's name in a session directory.
INJECTED_FILE = "injected.csv"
INJECTED_COLUMNS: tuple[str, ...] = (
    "time",
    "pair",
    "kind",
    "error",
    "event",
    "start",
    "end",
    "mean",
    "sd",
)
INJECTED_KINDS: tuple[str, ...] = ("nlos", "gross", "outage")
_NUMBERS = ("time", "error", "start", "end", "mean", "sd")
#: Numbers every row has (``error`` too, except for an outage).
_REQUIRED_NUMBERS = ("time", "start", "end")


def write_injected(frame: pd.DataFrame, path: Path) -> Path:
    """Write the injection records (columns :data:`INJECTED_COLUMNS`)."""
    return write_csv(frame, path, INJECTED_COLUMNS)


def read_injected(path: str | Path) -> pd.DataFrame:
    """Read and check ``injected.csv``; one-line InputError naming the line of a problem."""
    p = Path(path)
    try:
        frame = pd.read_csv(p, dtype={"pair": str, "kind": str, "event": str})
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise InputError(p, f"not a readable CSV table ({err})") from err
    missing = [c for c in INJECTED_COLUMNS if c not in frame.columns]
    if missing:
        raise InputError(
            p, f"missing columns {missing}; expected {','.join(INJECTED_COLUMNS)}", line=1
        )
    for col in _NUMBERS:
        values = pd.to_numeric(frame[col], errors="coerce")
        bad = values.isna() & frame[col].notna()
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(
                p, f"column '{col}': {frame[col].iloc[row]!r} is not a number", line=row + 2
            )
        frame[col] = values.astype(np.float64)
    for col in ("pair", "kind", "event"):
        empty = frame[col].isna().to_numpy()
        if empty.any():
            row = int(np.flatnonzero(empty)[0])
            raise InputError(p, f"column '{col}': empty", line=row + 2)
    kinds = frame["kind"].to_numpy(dtype=object)
    bad_kind = ~np.isin(kinds, INJECTED_KINDS)
    if bad_kind.any():
        row = int(np.flatnonzero(bad_kind)[0])
        raise InputError(
            p,
            f"kind {kinds[row]!r}; expected one of {', '.join(INJECTED_KINDS)}",
            line=row + 2,
        )
    for col in _REQUIRED_NUMBERS:
        absent = frame[col].isna().to_numpy()
        if absent.any():
            row = int(np.flatnonzero(absent)[0])
            raise InputError(p, f"column '{col}': empty; expected a number", line=row + 2)
    no_error = frame["error"].isna().to_numpy() & (kinds != "outage")
    if no_error.any():
        row = int(np.flatnonzero(no_error)[0])
        raise InputError(
            p, f"{kinds[row]} row without an error; expected metres added", line=row + 2
        )
    return frame


def session_injected(root: str | Path) -> tuple[Path, pd.DataFrame] | None:
    """``injected.csv`` of a session directory, read, with its path; None without one."""
    path = Path(root) / INJECTED_FILE
    if not Path(root).is_dir() or not path.is_file():
        return None
    return path, read_injected(path)
