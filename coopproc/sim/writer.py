"""Write a simulation: the session through the project's writers, the truth as CSV.

Layout of ``OUT``::

    session.toml, nav_<ID>.csv, ranges.csv, ref_<ID>.pos     (coopproc.io.write_session)
    mcap/<name>.mcap          (with mcap=True) the session as the files above hold it
    truth/traj_<ID>.csv        time, east, north, up, heading (true, nav rate)
    truth/distances.csv        time, pair, distance, error    (at every written range)
    truth/nlos_events.csv      pair, start, end, nominal_mean, realized_mean, epochs
    truth/gross_errors.csv     time, pair, error
    truth/dr_error.csv         time, platform, error_east, error_north, error_up, error_h
    truth/dr_params.csv        the dead-reckoning sensor errors each platform drew
    truth/nav_frames.csv       own-frame navigation: rotation and shift (single-auxiliary)
    truth/nav_faults.csv       dead-reckoning faults and nav gaps (only when there are any)
    truth/params.toml          the effective simulation parameters, scenario and seed
    imu_<ID>.csv, odo_<ID>.csv (imu_rate_hz > 0) raw IMU and odometer (coopproc.sim.imu)
    truth/imu_errors.csv       (imu_rate_hz > 0) the IMU errors and odometer scale drawn
    obs_<ID>.rnx, nav.rnx      (gnss_obs) RINEX 3.04 GPS observations per platform and the
                               ephemerides flown (RINEX 2.11: obs_<ID>.<yy>o, nav.<yy>n)
    truth/gnss_clock.csv       (gnss_obs) receiver clock bias and drift at every epoch
    truth/gnss_errors.csv      (gnss_obs) the terms of every pseudorange written
    README.md                  what this is and the command that makes it again

The output directory is written atomically (``coopproc.io.outdir.atomic_output_dir``).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
import tomli_w

from coopproc.gnss.rinex_write import gpst_to_calendar, write_nav, write_obs
from coopproc.io.outdir import atomic_output_dir, write_csv
from coopproc.model import Session
from coopproc.sim.params import SimParams, sparse_table
from coopproc.sim.truth import (
    DISTANCE_COLUMNS,
    DR_ERROR_COLUMNS,
    DR_PARAM_COLUMNS,
    GNSS_CLOCK_COLUMNS,
    GNSS_ERROR_COLUMNS,
    GROSS_ERROR_COLUMNS,
    IMU_ERROR_COLUMNS,
    NAV_FAULT_COLUMNS,
    NAV_FRAME_COLUMNS,
    NLOS_TRUTH_COLUMNS,
    SimulatedGnss,
    Simulation,
    Truth,
)

__all__ = [
    "command_line",
    "describe_simulation",
    "session_as_written",
    "write_gnss",
    "write_simulation",
    "write_truth",
]


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
    if len(truth.imu_errors):
        written.append(write_csv(truth.imu_errors, directory / "imu_errors.csv", IMU_ERROR_COLUMNS))
    if len(truth.nav_faults):
        faults = directory / "nav_faults.csv"
        written.append(write_csv(truth.nav_faults, faults, NAV_FAULT_COLUMNS))
    params = {**(header or {}), "params": sparse_table(truth.params)}
    path = directory / "params.toml"
    path.write_text(tomli_w.dumps(params), encoding="utf-8")
    written.append(path)
    return written


def write_simulation(
    sim: Simulation,
    out_dir: Path,
    *,
    mcap: bool = False,
    force: bool = False,
    mcap_encoding: Literal["json", "ros2"] = "json",
) -> list[Path]:
    """Write the session files and ``truth/`` into ``out_dir``; returns the final paths.

    ``mcap``: also write the same session as one MCAP file ``mcap/<scenario>.mcap``
    (``mcap_encoding``: JSON channels or ROS 2 CDR messages).
    An existing non-empty ``out_dir`` is replaced only with ``force``.
    """
    from coopproc.io import write_mcap, write_session

    out_dir = Path(out_dir)
    with atomic_output_dir(out_dir, force=force) as tmp:
        written = list(write_session(sim.session, tmp))
        if sim.gnss is not None:
            written.extend(write_gnss(sim.gnss, sim.truth.params, tmp))
        if mcap:
            (tmp / "mcap").mkdir()
            target = tmp / "mcap" / f"{sim.scenario}.mcap"
            as_files, llh = session_as_written(sim.session, tmp / "mcap" / "session")
            mcap_file = write_mcap(as_files, target, encoding=mcap_encoding, reference_llh=llh)
            written.append(mcap_file)
        header = {"scenario": sim.scenario, "seed": sim.seed}
        written.extend(write_truth(sim.truth, tmp / "truth", header=header))
        readme = tmp / "README.md"
        text = describe_simulation(sim, out_dir.name, mcap=mcap, mcap_encoding=mcap_encoding)
        readme.write_text(text, encoding="utf-8")
        written.append(readme)
        relative = [Path(p).resolve().relative_to(tmp.resolve()) for p in written]
    return [out_dir / rel for rel in relative]


def write_gnss(gnss: SimulatedGnss, params: SimParams, directory: Path) -> list[Path]:
    """The RINEX observation files, the navigation file and the GNSS truth tables."""
    version = gnss.rinex_version
    year = gpst_to_calendar(params.gps_week * 604800.0 + params.start_tow_s)[0]
    suffix = "rnx" if version == 3 else f"{year % 100:02d}"
    written = [
        write_obs(table, directory / f"obs_{pid}.{suffix}{'' if version == 3 else 'o'}", version)
        for pid, table in sorted(gnss.observations.items())
    ]
    nav = directory / f"nav.{suffix}{'' if version == 3 else 'n'}"
    written.append(write_nav(gnss.ephemerides, nav, version))
    truth = directory / "truth"
    truth.mkdir(exist_ok=True)
    written.append(write_csv(gnss.clock, truth / "gnss_clock.csv", GNSS_CLOCK_COLUMNS))
    written.append(write_csv(gnss.errors, truth / "gnss_errors.csv", GNSS_ERROR_COLUMNS))
    return written


def session_as_written(session: Session, scratch: Path) -> tuple[Session, dict[str, np.ndarray]]:
    """The session as its written files give it back (every reference Q kept), and the
    geodetic positions of its ``ref_<ID>.pos`` files.

    This is what the MCAP holds: written from the in-memory session it would carry the
    digits the CSV and .pos files round away (nav to 1 um, references to 1e-9 deg and
    1 ms), and the two forms of one simulation would not give the same tables.
    """
    from coopproc.io import read_session, write_session
    from coopproc.io.rtklib_pos import read_pos

    every_q = dataclasses.replace(session.config, reference_quality=tuple(range(7)))
    write_session(dataclasses.replace(session, config=every_q), scratch)
    read = read_session(scratch)
    llh = {pid: read_pos(scratch / f"ref_{pid}.pos", pid).position for pid in read.reference}
    shutil.rmtree(scratch)
    return dataclasses.replace(read, config=session.config, platforms=session.platforms), llh


def _toml_value(value: Any) -> str:
    """``value`` (a parameter: scalar, tuple, or tuple of spec dataclasses) as TOML text."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        items = (
            f"{f.name} = {_toml_value(getattr(value, f.name))}" for f in dataclasses.fields(value)
        )
        return "{" + ", ".join(items) + "}"
    return "[" + ", ".join(_toml_value(v) for v in value) + "]"


def command_line(
    sim: Simulation, out_name: str, *, mcap: bool = False, mcap_encoding: str = "json"
) -> str:
    """A ``coopproc simulate`` command that makes ``sim`` again (overrides as --set TOML)."""
    from coopproc.sim.engine import scenario_params

    default = scenario_params(sim.scenario)
    params = sim.truth.params
    parts = ["coopproc simulate", out_name, "--scenario", sim.scenario, "--seed", str(sim.seed)]
    if params.duration_s != default.duration_s:
        parts += ["--duration", f"{params.duration_s:g}"]
    if params.platforms != default.platforms:
        parts += ["--platforms", str(params.platforms)]
    rescaled = scenario_params(sim.scenario, duration_s=params.duration_s)
    for f in dataclasses.fields(params):
        value, base = getattr(params, f.name), getattr(rescaled, f.name)
        if f.name in ("duration_s", "platforms") or value == base:
            continue
        text = f"{f.name}={_toml_value(value)}"
        parts += ["--set", f"'{text}'" if any(c in text for c in ' []{}"') else text]
    if mcap:
        parts.append("--mcap")
        if mcap_encoding != "json":
            parts += ["--mcap-encoding", mcap_encoding]
    return " ".join(parts)


def describe_simulation(
    sim: Simulation, out_name: str, *, mcap: bool = False, mcap_encoding: str = "json"
) -> str:
    """The README.md of a simulated session directory."""
    from coopproc.sim.scenarios import SCENARIOS

    p = sim.truth.params
    session = sim.session
    roles = ", ".join(f"{pid} ({session.platforms[pid].role})" for pid in session.platform_ids)
    events = sim.truth.nlos_events
    lines = [
        f"# Simulated session: {sim.scenario}, seed {sim.seed}",
        "",
        "This directory is NOT a real recording: coopproc's simulator made it, with known",
        f"truth, as a stand-in for {SCENARIOS[sim.scenario].description}.",
        "",
        "Made with (byte-for-byte reproducible):",
        "",
        "```",
        command_line(sim, out_name, mcap=mcap, mcap_encoding=mcap_encoding),
        "```",
        "",
        "## What is in it",
        "",
        f"- platforms: {roles}",
        f"- {p.duration_s:g} s from GPS week {p.gps_week}, TOW {p.start_tow_s:g} s "
        f"(session time base `gps_tow`); ENU origin {list(p.origin_llh)}",
        f"- `nav_<ID>.csv`: each platform's own navigation at {p.nav_rate_hz:g} Hz (leaders: "
        f"GNSS/INS, {100 * p.leader_sigma_m:g} cm noise{_leader_extras(p)}; followers: "
        f"INS/odometer dead reckoning, gyro bias up to {p.gyro_bias_dph:g} deg/h, odometer "
        f"scale error {100 * p.odo_scale_sigma:g} % 1-sigma{_dr_extras(p)})",
        _ranges_line(p),
        f"- `ref_<ID>.pos`: GNSS-PPK reference (RTKLIB .pos, GPST) at {p.ref_rate_hz:g} Hz, "
        f"{100 * p.ref_sigma_m:g} cm noise, a few float (Q = 2) segments",
        "- `session.toml`: roles, drift sigmas, origin, time base, UWB sigma",
    ]
    if sim.gnss is not None:
        v3 = sim.gnss.rinex_version == 3
        lines.append(
            f"- `{'obs_<ID>.rnx' if v3 else 'obs_<ID>.<yy>o'}`, "
            f"`{'nav.rnx' if v3 else 'nav.<yy>n'}`: simulated GPS L1 observations of every "
            f"platform at {p.gnss_rate_hz:g} Hz (RINEX {'3.04' if v3 else '2.11'}) and the "
            "broadcast ephemerides they fly; truth in `truth/gnss_clock.csv`, "
            "`truth/gnss_errors.csv` (e.g. `coopproc spp obs_<ID>.rnx --nav nav.rnx -o ID.pos`)"
        )
    if mcap:
        encoding = "ROS 2 CDR" if mcap_encoding == "ros2" else "JSON"
        lines.append(
            f"- `mcap/{sim.scenario}.mcap`: the same session as one MCAP file ({encoding})"
        )
    lines += [
        "- `truth/`: what a real recording cannot give: `traj_<ID>.csv` true trajectories, "
        "`distances.csv` true distance and total range error at every range, "
        "`nlos_events.csv`, `gross_errors.csv`, `dr_error.csv` (navigation error over time), "
        "`dr_params.csv` (the sensor errors drawn), `nav_frames.csv`, `params.toml` (every "
        "simulation parameter)" + (", `nav_faults.csv`" if len(sim.truth.nav_faults) else ""),
        "",
        "## NLOS events",
        "",
    ]
    if len(events):
        lines += ["| pair | start (TOW s) | end (TOW s) | nominal mean (m) | realized mean (m) |"]
        lines += ["|---|---|---|---|---|"]
        for row in events.itertuples():
            lines.append(
                f"| {row.pair} | {row.start:.1f} | {row.end:.1f} | {row.nominal_mean:.3f} "
                f"| {row.realized_mean:.4f} |"
            )
    else:
        lines.append("None.")
    faults = sim.truth.nav_faults
    if len(faults):
        lines += ["", "## Navigation faults (truth/nav_faults.csv)", ""]
        lines += [
            "| platform | fault | start (TOW s) | end (TOW s) | value |",
            "|---|---|---|---|---|",
        ]
        for row in faults.itertuples():
            lines.append(
                f"| {row.platform} | {row.fault} | {row.start:.1f} | {row.end:.1f} "
                f"| {row.value:g} |"
            )
    use = f"coopproc run {out_name} -o out/{out_name}"
    if sim.scenario in ("single-auxiliary", "multi-auxiliary"):
        aux = ",".join(pid for pid in session.platform_ids if pid != "T")
        use = f"coopproc locate {out_name} --target T --aux {aux} -o out/{out_name}"
    lines += ["", "## Use it", "", "```", f"coopproc validate {out_name}", use]
    if mcap:
        lines.append(f"coopproc info {out_name}/mcap/{sim.scenario}.mcap")
    lines += [
        "```",
        "",
        "The command above with `--force` makes this directory again (it replaces it).",
        "See docs/simulator.md for the models and every parameter.",
        "",
    ]
    return "\n".join(lines)


def _leader_extras(p: SimParams) -> str:
    text = f" + {100 * p.leader_white_m:g} cm white noise" if p.leader_white_m > 0 else ""
    if p.leader_velocity:
        text += f", velocities with {100 * p.leader_vel_sigma_mps:g} cm/s noise"
    return text


def _dr_extras(p: SimParams) -> str:
    parts = []
    if p.heading_drift_dpm > 0:
        parts.append(f"{p.heading_drift_dpm:g} deg/min heading-rate fault on one follower")
    if p.odo_scale_fault[1] > 0:
        low, high = (100 * v for v in p.odo_scale_fault)
        parts.append(f"odometer scale faults of {low:g}-{high:g} %")
    if p.slip_rate_per_hour > 0:
        parts.append(f"{p.slip_rate_per_hour:g} wheel slips per hour")
    if p.nav_gaps:
        parts.append(f"{len(p.nav_gaps)} nav gap(s)")
    return "".join(f"; {part}" for part in parts)


def _ranges_line(p: SimParams) -> str:
    if p.exact_ranges:
        return (
            f"- `ranges.csv`: UWB ranges at {p.range_rate_hz:g} Hz per pair, EXACT: the true "
            "distances (no noise, NLOS, gross errors, dropouts or outages; declared sigma "
            f"{p.uwb_declared_sigma_m:g} m)" + (", `rssi` column (dBm)" if p.rssi else "")
        )
    return (
        f"- `ranges.csv`: UWB ranges at {p.range_rate_hz:g} Hz per pair, white noise "
        f"{p.uwb_noise_m:g} m (declared sigma {p.uwb_declared_sigma_m:g} m), "
        f"{100 * p.dropout_rate:g} % dropouts" + (", `rssi` column (dBm)" if p.rssi else "")
    )
