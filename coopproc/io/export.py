"""Export a run's positions (``positions.csv``) as trajectory files other tools read.

One file per platform and method, ``<platform>.<method>.<ext>``, in one of the formats of
:data:`FORMATS` (docs/export.md): TUM and KITTI (ENU, as in positions.csv), RTKLIB
``.pos``, GeoJSON and KML (geodetic, through the session's ENU origin). The writers are in
:mod:`coopproc.io.export_formats`; this module picks the rows and reads the run's time
base and origin (run.json ``session``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from coopproc import timeconv
from coopproc.configtools import nearest
from coopproc.errors import ConfigError, CoopprocError, InputError, OutputError
from coopproc.io import export_formats as fmt
from coopproc.io.outdir import atomic_output_dir, check_output_dir
from coopproc.io.session_toml import read_session_toml
from coopproc.model import FloatArray

__all__ = [
    "FORMATS",
    "RunFrame",
    "Track",
    "export_tracks",
    "run_frame",
    "select_tracks",
]

#: Format name -> file name extension (after ``<platform>.<method>.``).
FORMATS: dict[str, str] = {
    "tum": "tum",
    "kitti": "kitti.txt",
    "pos": "pos",
    "geojson": "geojson",
    "kml": "kml",
}

#: Formats that need the geodetic origin (and, for ``pos``, absolute times).
GEODETIC_FORMATS = ("pos", "geojson", "kml")

_NAME = re.compile(r"\A[A-Za-z0-9_-]+\Z")


@dataclass(frozen=True)
class RunFrame:
    """The run's time base and ENU origin, and why a missing one is missing."""

    time_base: str | None
    gps_week: int | None
    origin_llh: tuple[float, float, float] | None
    #: Says, for messages, why the origin is None.
    no_origin: str = ""
    #: Says, for messages, why there are no absolute times.
    no_time: str = ""

    def gpst(self, time_s: FloatArray) -> FloatArray | None:
        """GPST seconds since the GPS epoch of session times (None: not absolute)."""
        if self.time_base == "gps_tow" and self.gps_week is not None:
            return timeconv.week_tow_to_gpst(self.gps_week, time_s)
        if self.time_base == "unix":
            return timeconv.unix_to_gpst(time_s)
        return None

    def why_no_time(self) -> str:
        if self.no_time:
            return self.no_time
        if self.time_base == "gps_tow":
            return (
                "the run's gps_tow times have no GPS week (no .pos file, no [time] "
                "gps_week): set [time] gps_week in session.toml and rerun `coopproc run`"
            )
        return f"the run's time base is {self.time_base!r}, not GPS or Unix time"


@dataclass(frozen=True, eq=False)
class Track:
    """The positions.csv rows of one platform and method, in time order."""

    platform: str
    method: str
    time_s: FloatArray
    enu_m: FloatArray


def run_frame(info: Mapping[str, Any], run_json: str | Path) -> RunFrame:
    """The time base and origin run.json ``session`` records.

    A run.json written before coopproc recorded them: the ``[time]`` and ``[frame]``
    keys of the session's session.toml (at the recorded session path), when it is there.
    """
    session = info.get("session")
    session = session if isinstance(session, Mapping) else {}
    if "origin_llh" in session or "time_base" in session:
        origin = _origin(session.get("origin_llh"), run_json)
        base = session.get("time_base")
        week = session.get("gps_week")
        if base not in ("gps_tow", "unix", "relative") or not (
            week is None or isinstance(week, int)
        ):
            raise InputError(
                run_json,
                f'key "session": time_base {base!r}, gps_week {week!r}; expected "gps_tow", '
                '"unix" or "relative", and a week number or null',
            )
        no_origin = (
            "the session has none (no [frame] origin in session.toml, no geodetic or ECEF "
            "file): set [frame] origin in session.toml and rerun `coopproc run`"
        )
        return RunFrame(base, week, origin, no_origin=no_origin if origin is None else "")
    return _frame_from_toml(str(session.get("path", "")), run_json)


def _origin(value: Any, run_json: str | Path) -> tuple[float, float, float] | None:
    if value is None:
        return None
    if (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        return float(value[0]), float(value[1]), float(value[2])
    raise InputError(run_json, f'key "session" origin_llh: {value!r}; expected [lat, lon, height]')


def _frame_from_toml(session_path: str, run_json: str | Path) -> RunFrame:
    old = f"{run_json} records no time base or origin (written by an older coopproc)"
    root = Path(session_path) if session_path else None
    toml = None
    if root is not None:
        toml = root / "session.toml" if root.is_dir() else root.with_name("session.toml")
    if toml is None or not toml.is_file():
        why = f"{old} and its session.toml is not at {toml}: rerun `coopproc run`"
        return RunFrame(None, None, None, no_origin=why, no_time=why)
    try:
        read = read_session_toml(toml)
    except CoopprocError as err:
        why = f"{old} and {toml} cannot be read ({err}): rerun `coopproc run`"
        return RunFrame(None, None, None, no_origin=why, no_time=why)
    cfg = read.config
    return RunFrame(
        cfg.time_base if read.base_given else None,
        cfg.gps_week,
        cfg.origin_llh,
        no_origin=f"{old} and {toml} has no [frame] origin: rerun `coopproc run`",
        no_time=f"{old} and {toml} has no [time] base: rerun `coopproc run`",
    )


def _pick(option: str, what: str, wanted: Sequence[str] | None, have: Sequence[str]) -> list[str]:
    if wanted is None:
        return list(have)
    for name in wanted:
        if name not in have:
            same = [h for h in have if h.lower() == name.lower()]
            hint = f" (did you mean '{same[0]}'?)" if same else nearest(name, have)
            if not hint.startswith(" (did"):
                hint = f" (the run has {', '.join(have) or 'none'})"
            raise ConfigError(f"{option}: unknown {what} '{name}'{hint}")
    return list(dict.fromkeys(wanted))


def select_tracks(
    positions: pd.DataFrame,
    *,
    methods: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
) -> tuple[list[Track], list[str]]:
    """The tracks of the chosen platforms and methods (default: all), and notes.

    Platforms in sorted order, methods in positions.csv order; rows without a position
    are left out (with a note). Unknown names are a ConfigError naming the nearest one.
    """
    have_methods = list(dict.fromkeys(positions["method"].astype(str)))
    have_platforms = sorted(set(positions["platform"].astype(str)))
    chosen_methods = _pick("--methods", "method", methods, have_methods)
    chosen_platforms = _pick("--platforms", "platform", platforms, have_platforms)
    tracks: list[Track] = []
    notes: list[str] = []
    groups = dict(list(positions.groupby(["platform", "method"], sort=False)))
    for pid in chosen_platforms:
        for method in chosen_methods:
            rows = groups.get((pid, method))
            if rows is None or not len(rows):
                continue
            for name in (pid, method):
                if not _NAME.match(name):
                    raise InputError(
                        "positions.csv", f"name {name!r}: expected letters, digits, '_' or '-'"
                    )
            rows = rows.sort_values("time", kind="stable")
            enu = rows[["east", "north", "up"]].to_numpy(dtype=np.float64)
            time_s = rows["time"].to_numpy(dtype=np.float64)
            ok = np.isfinite(enu).all(axis=1) & np.isfinite(time_s)
            if not ok.all():
                notes.append(f"{pid}.{method}: {int((~ok).sum())} rows without a position left out")
            if ok.any():
                tracks.append(Track(pid, method, time_s[ok], enu[ok]))
    if not tracks:
        raise ConfigError(
            f"no positions of platforms {', '.join(chosen_platforms)} with methods "
            f"{', '.join(chosen_methods)} in the run"
        )
    return tracks, notes


def check_export_dir(path: str | Path, run_dir: str | Path, *, force: bool = False) -> Path:
    """Raise OutputError now if ``path`` cannot take the export (never in the run)."""
    target, run = Path(path).resolve(), Path(run_dir).resolve()
    if target.is_relative_to(run):
        raise OutputError(
            f"{path}: inside the run directory {run_dir}; export writes elsewhere "
            "(the run is never modified)"
        )
    return check_output_dir(path, force=force, protect=[run])


def _writer(name: str, frame: RunFrame) -> Callable[[Track, Path], list[Path]]:
    """The writer of format ``name``; an OutputError when the run lacks what it needs."""
    if name not in FORMATS:
        raise ConfigError(f"unknown export format '{name}'{nearest(name, FORMATS)}")
    if name in GEODETIC_FORMATS and frame.origin_llh is None:
        raise OutputError(f"--format {name} needs the session's geodetic origin: {frame.no_origin}")
    if name == "pos" and frame.gpst(np.zeros(1)) is None:
        raise OutputError(f"--format pos needs GPS times: {frame.why_no_time()}")
    origin = frame.origin_llh or (0.0, 0.0, 0.0)

    def write(track: Track, path: Path) -> list[Path]:
        if name == "tum":
            return [fmt.write_tum_track(track.platform, track.time_s, track.enu_m, path)]
        if name == "kitti":
            return fmt.write_kitti(track.time_s, track.enu_m, path)
        gpst = frame.gpst(track.time_s)
        if name == "pos":
            assert gpst is not None
            return [fmt.write_pos_track(gpst, track.enu_m, origin, path)]
        facts = fmt.TrackFacts(track.platform, track.method, track.time_s, gpst, frame.time_base)
        if name == "geojson":
            return [fmt.write_geojson(facts, track.enu_m, origin, path)]
        return [fmt.write_kml(facts, track.enu_m, origin, path)]

    return write


def export_tracks(
    tracks: Sequence[Track],
    out_dir: str | Path,
    format_name: str,
    frame: RunFrame,
    *,
    run_dir: str | Path,
    force: bool = False,
) -> list[Path]:
    """Write each track as ``out_dir/<platform>.<method>.<ext>`` (atomically); the paths.

    ``run_dir``: the run exported, never written (``out_dir`` may not be in it).
    """
    write = _writer(format_name, frame)
    check_export_dir(out_dir, run_dir, force=force)
    ext = FORMATS[format_name]
    written: list[Path] = []
    with atomic_output_dir(out_dir, force=force, protect=[Path(run_dir)]) as tmp:
        for track in tracks:
            written += write(track, tmp / f"{track.platform}.{track.method}.{ext}")
    return [Path(out_dir) / p.name for p in written]
