"""Write a simulation: the session through the project's writers, the truth as CSV.

Layout of ``OUT``::

    session.toml, nav_<ID>.csv, ranges.csv, ref_<ID>.pos     (coopproc.io.write_session)
    mcap/<name>.mcap                                          (with mcap=True)
    truth/traj_<ID>.csv        time, east, north, up, heading (true, nav rate)
    truth/distances.csv        time, pair, distance, error    (at every written range)
    truth/nlos_events.csv      pair, start, end, nominal_mean, realized_mean, epochs
    truth/gross_errors.csv     time, pair, error
    truth/dr_error.csv         time, platform, error_east, error_north, error_up, error_h
    truth/dr_params.csv        the dead-reckoning sensor errors each platform drew
    truth/nav_frames.csv       own-frame navigation: rotation and shift (single-auxiliary)
    truth/params.toml          the effective simulation parameters, scenario and seed

The output directory is written atomically (``coopproc.outdir.atomic_output_dir``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import tomli_w

from coopproc.configtools import to_table
from coopproc.outdir import atomic_output_dir, write_csv
from coopproc.sim.truth import (
    DISTANCE_COLUMNS,
    DR_ERROR_COLUMNS,
    DR_PARAM_COLUMNS,
    GROSS_ERROR_COLUMNS,
    NAV_FRAME_COLUMNS,
    NLOS_TRUTH_COLUMNS,
    Simulation,
    Truth,
)

__all__ = ["write_simulation", "write_truth"]


def write_truth(
    truth: Truth, directory: Path, *, header: dict[str, Any] | None = None
) -> list[Path]:
    """Write the truth tables into ``directory`` (created); returns the files written."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for pid, traj in sorted(truth.trajectories.items()):
        frame = pd.DataFrame(
            {
                "time": traj.time_s,
                "east": traj.enu_m[:, 0],
                "north": traj.enu_m[:, 1],
                "up": traj.enu_m[:, 2],
            }
        )
        if traj.heading_deg is not None:
            frame["heading"] = traj.heading_deg
        written.append(write_csv(frame, directory / f"traj_{pid}.csv"))
    tables = (
        ("distances.csv", truth.distances, DISTANCE_COLUMNS),
        ("nlos_events.csv", truth.nlos_events, NLOS_TRUTH_COLUMNS),
        ("gross_errors.csv", truth.gross_errors, GROSS_ERROR_COLUMNS),
        ("dr_error.csv", truth.dr_error, DR_ERROR_COLUMNS),
        ("dr_params.csv", truth.dr_params, DR_PARAM_COLUMNS),
        ("nav_frames.csv", truth.nav_frames, NAV_FRAME_COLUMNS),
    )
    for name, frame, columns in tables:
        written.append(write_csv(frame, directory / name, columns))
    params = {**(header or {}), "params": to_table(truth.params)}
    path = directory / "params.toml"
    path.write_text(tomli_w.dumps(params), encoding="utf-8")
    written.append(path)
    return written


def write_simulation(
    sim: Simulation, out_dir: Path, *, mcap: bool = False, force: bool = False
) -> list[Path]:
    """Write the session files and ``truth/`` into ``out_dir``; returns the final paths.

    ``mcap``: also write the same session as one MCAP file ``mcap/<scenario>.mcap``.
    An existing non-empty ``out_dir`` is replaced only with ``force``.
    """
    from coopproc.io import write_mcap, write_session

    out_dir = Path(out_dir)
    with atomic_output_dir(out_dir, force=force) as tmp:
        written = list(write_session(sim.session, tmp))
        if mcap:
            (tmp / "mcap").mkdir()
            written.append(write_mcap(sim.session, tmp / "mcap" / f"{sim.scenario}.mcap"))
        header = {"scenario": sim.scenario, "seed": sim.seed}
        written.extend(write_truth(sim.truth, tmp / "truth", header=header))
        relative = [Path(p).resolve().relative_to(tmp.resolve()) for p in written]
    return [out_dir / rel for rel in relative]
