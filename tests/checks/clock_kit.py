"""Shift a session file's times by a known offset (the clock-offset tests' known answers)."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pandas as pd


def shift_csv(path: Path, seconds: float) -> None:
    """Add ``seconds`` to the ``time`` column of a CSV (nav_<ID>.csv, ranges.csv)."""
    frame = pd.read_csv(path)
    frame["time"] = frame["time"] + seconds
    frame.to_csv(path, index=False, float_format="%.6f")


def shift_pos(path: Path, seconds: float) -> None:
    """Add ``seconds`` to the GPST calendar times of an RTKLIB .pos file."""
    out = []
    for line in path.read_text().splitlines():
        if line.startswith("%") or not line.strip():
            out.append(line)
            continue
        date, clock, rest = line.split(None, 2)
        when = dt.datetime.strptime(f"{date} {clock}", "%Y/%m/%d %H:%M:%S.%f")
        when += dt.timedelta(seconds=seconds)
        out.append(f"{when:%Y/%m/%d %H:%M:%S.%f}"[:-3] + "   " + rest)
    path.write_text("\n".join(out) + "\n")
