"""``[time.offsets]``: each file's seconds subtracted from its times on reading.

The constants a user gives for files whose clock runs ahead (or behind), e.g. after
``coopproc validate`` named one (docs/formats.md "Clock offsets"): subtracted in the
session time base, before the time checks, so that the checks see the corrected times.
``[time] offsets = "estimate"`` is :mod:`coopproc.checks.clock`'s, after reading.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Protocol

import numpy as np

from coopproc.errors import ConfigError, CoopprocError
from coopproc.io._common import RawTrajectory
from coopproc.io.ranges_csv import RangesRead
from coopproc.io.timebase import TimedFile
from coopproc.model import RangeTable

__all__ = ["subtract_offsets"]


class _Loader(Protocol):
    notes: list[str]
    failed: set[str]

    def add(self, err: CoopprocError) -> None: ...


def subtract_offsets(
    offsets: Mapping[str, float],
    where: str,
    nav_raw: dict[str, RawTrajectory],
    ref_raw: dict[str, RawTrajectory],
    ranges: RangesRead | None,
    files: list[TimedFile],
    loader: _Loader,
) -> RangesRead | None:
    """Subtract each key's seconds (``ranges``, ``nav.<ID>``, ``ref.<ID>``) from its
    file's times (``nav_raw``, ``ref_raw`` and ``files`` in place), one note each; a key
    naming no file is a problem. Returns the ranges, shifted when given."""
    for key, seconds in offsets.items():
        if key == "ranges":
            if ranges is not None:
                frame = ranges.table.frame.copy()
                frame["time"] = frame["time"].to_numpy(dtype=np.float64) - seconds
                table = RangeTable.with_id_codes(frame, ranges.table.source, ranges.table.id_codes)
                ranges = RangesRead(table, ranges.notes, ranges.where, ranges.order)
                loader.notes.append(f"[time.offsets] ranges: {seconds:+g} s subtracted")
            continue
        kind, pid = key.split(".", 1)
        group = nav_raw if kind == "nav" else ref_raw
        if pid not in group:
            if not (kind == "nav" and pid in loader.failed):
                known = ", ".join(sorted(f"{kind}.{p}" for p in group)) or "none"
                loader.add(
                    ConfigError(
                        f"{where} [time.offsets] {key}: no {kind} file of {pid}; "
                        f"expected one of {known}"
                    )
                )
            continue
        raw = group[pid]
        group[pid] = replace(raw, time_s=raw.time_s - seconds)
        for i, f in enumerate(files):
            if f.source == raw.source:
                files[i] = replace(f, time_s=group[pid].time_s)
        loader.notes.append(f"[time.offsets] {key}: {seconds:+g} s subtracted ({raw.source})")
    return ranges
