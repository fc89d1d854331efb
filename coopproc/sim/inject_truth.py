"""``truth/`` of an injected session: what stays true, what the injection changes.

The true trajectories, the dead-reckoning errors and parameters stay true: ``truth/`` is
copied byte for byte. Of a coopproc simulation's truth (:mod:`coopproc.sim.writer`) three
range-level tables would no longer describe the new ranges, so they are updated:

- ``distances.csv`` (one row per range of ``ranges.csv``, same order): the injected error
  added to ``error`` (= range - true distance), the rows of removed ranges left out;
- ``nlos_events.csv``: one row per injected NLOS event appended (``nominal_mean`` the
  asked mean, ``realized_mean`` the mean of the errors added, ``epochs`` their count);
- ``gross_errors.csv``: one row per range a gross error was added to.

Any other ``truth/`` (a real recording's, say) is copied as it is: ``injected.csv`` lists
what was added on top of it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.io.outdir import write_csv
from coopproc.sim.inject_csv import RangesText
from coopproc.sim.truth import DISTANCE_COLUMNS, GROSS_ERROR_COLUMNS, NLOS_TRUTH_COLUMNS

__all__ = ["update_truth"]


def _header(path: Path) -> tuple[str, ...]:
    if not path.is_file():
        return ()
    with path.open(encoding="utf-8") as fh:
        return tuple(c.strip() for c in fh.readline().strip().split(","))


def _append(path: Path, lines: list[str]) -> None:
    if not lines:
        return
    text = path.read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text += "\n"
    path.write_text(text + "".join(lines), encoding="utf-8")


def _distances(
    path: Path, text: RangesText, added: dict[int, float], removed: set[int]
) -> str | None:
    """Update distances.csv; the reason it was left as copied, else None."""
    frame = pd.read_csv(path, dtype={"pair": str})
    times = frame["time"].to_numpy(dtype=np.float64)
    if len(frame) != len(text.rows) or not np.allclose(times, text.time_s, rtol=0, atol=2e-6):
        return "its rows are not those of the ranges file"
    error = frame["error"].to_numpy(dtype=np.float64).copy()
    for k, e in added.items():
        error[k] += e
    frame["error"] = error
    keep = np.ones(len(frame), dtype=bool)
    keep[list(removed)] = False
    write_csv(frame[keep], path, DISTANCE_COLUMNS)
    return None


def update_truth(
    truth: Path,
    text: RangesText,
    records: pd.DataFrame,
    added: dict[int, float],
    removed: set[int],
) -> list[str]:
    """Update the copied ``truth`` directory (module doc); returns notes for the user."""
    if not truth.is_dir():
        return []
    updated, notes = [], []
    distances = truth / "distances.csv"
    if _header(distances) == DISTANCE_COLUMNS:
        why = _distances(distances, text, added, removed)
        if why is None:
            updated.append("distances.csv")
        else:
            notes.append(f"truth/distances.csv copied as it is: {why}")
    nlos_path = truth / "nlos_events.csv"
    if _header(nlos_path) == NLOS_TRUTH_COLUMNS:
        nlos = records[records["kind"] == "nlos"]
        lines = [
            f"{g['pair'].iloc[0]},{g['start'].iloc[0]:.6f},{g['end'].iloc[0]:.6f},"
            f"{g['mean'].iloc[0]:.6f},{g['error'].mean():.6f},{len(g)}\n"
            for _, g in nlos.groupby("event", sort=False)
        ]
        _append(nlos_path, lines)
        updated.append("nlos_events.csv")
    gross_path = truth / "gross_errors.csv"
    if _header(gross_path) == GROSS_ERROR_COLUMNS:
        gross = records[records["kind"] == "gross"]
        _append(
            gross_path,
            [
                f"{t:.6f},{p},{e:.6f}\n"
                for t, p, e in zip(gross["time"], gross["pair"], gross["error"], strict=True)
            ],
        )
        updated.append("gross_errors.csv")
    if updated:
        notes.append(f"truth/{', '.join(updated)}: the injected errors added")
    else:
        notes.append("truth/ copied as it is; injected.csv lists what was added on top of it")
    return notes
