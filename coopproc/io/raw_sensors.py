"""A session's raw-sensor files read and attached to its platforms (DATA.md "Raw sensors").

``imu_<ID>.csv`` and ``odo_<ID>.csv`` of a session directory, and the IMU topics of a
ROS bag, are read and checked (:mod:`coopproc.io.imu_csv`, :mod:`coopproc.io.odo_csv`)
into :class:`~coopproc.sensors.ImuData` / :class:`~coopproc.sensors.OdometerData` by
platform id. A file of a platform the session does not have (no navigation file, not in
session.toml ``[platforms]``) is a one-line error, as is an odometer whose distance
says km/h against the platform's navigation. Each file read gets one note.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import CoopprocError, InputError
from coopproc.io._common import InputProblems, Locator
from coopproc.io.imu_csv import IMU_RATE_COLUMNS, checked_imu, frame_problem, read_imu_csv
from coopproc.io.odo_csv import odometer_scale_problem, read_odo_csv
from coopproc.io.outdir import write_csv
from coopproc.io.registry import sensor_note
from coopproc.io.rosbag_read import ImuSamples
from coopproc.model import Platform, SensorFile, Session, Trajectory
from coopproc.sensors import ImuData, OdometerData

__all__ = [
    "RawSensors",
    "attach_decoded",
    "bag_imu",
    "imu_note",
    "odometer_note",
    "read_raw_sensors",
    "sensor_notes",
    "write_imu_csv",
    "write_odo_csv",
]

RawSensors = tuple[dict[str, ImuData], dict[str, OdometerData]]


def imu_note(imu: ImuData) -> str:
    form = "increments" if imu.form == "increment" else "rates"
    return (
        f"{imu.source}: IMU samples of {imu.platform} read ({imu.time_s.size} {form} at "
        f"{imu.rate_hz:.4g} Hz, {imu.duration_s:.1f} s); for the INS methods with ranges to "
        "anchors (ins*)"
    )


def odometer_note(odo: OdometerData) -> str:
    form = {"wheels": "wheel speeds", "twist": "twists"}.get(odo.form, "speeds")
    use = (
        "for odo_uwb with ranges to anchors"
        if odo.yaw_rate_radps is not None
        else "for odo_uwb with ranges to anchors and an IMU (the yaw rate)"
    )
    return (
        f"{odo.source}: odometer {form} of {odo.platform} read ({odo.time_s.size} at "
        f"{odo.rate_hz:.4g} Hz, {odo.duration_s:.1f} s); {use}"
    )


def _unknown(path: Path, kind: str, pid: str, known: Sequence[str]) -> InputError:
    return InputError(
        path,
        f"{kind} of platform {pid}, which the session does not have (platforms: "
        f"{', '.join(known) or 'none'}); expected nav_{pid}.csv or [platforms.{pid}] in "
        "session.toml",
    )


def read_raw_sensors(
    files: Sequence[SensorFile],
    platforms: Mapping[str, Platform],
    nav: Mapping[str, Trajectory],
    problems: list[CoopprocError],
    notes: list[str],
) -> RawSensors:
    """Read the ``imu``/``odo`` CSV files among ``files``; problems and notes appended."""
    imu: dict[str, ImuData] = {}
    odo: dict[str, OdometerData] = {}
    known = sorted(platforms)
    for f in files:
        if f.kind not in ("imu", "odo") or f.platform is None or not f.path.is_file():
            continue
        if not f.path.name.lower().startswith(("imu_", "odo_")):
            continue  # a bag listed as the source of its IMU topics
        pid = f.platform
        what = "IMU samples" if f.kind == "imu" else "odometer speeds"
        if pid not in platforms:
            problems.append(_unknown(f.path, what, pid, known))
            continue
        try:
            if f.kind == "imu":
                data_imu = read_imu_csv(f.path, pid)
                frame = "" if platforms[pid].imu_mounting_deg else frame_problem(data_imu)
                if frame:
                    raise InputError(f.path, frame)
                imu[pid] = data_imu
                notes.extend([*data_imu.notes, imu_note(data_imu)])
            else:
                data = read_odo_csv(f.path, pid, platforms[pid].wheelbase_m)
                if pid in nav:
                    unit = odometer_scale_problem(data, nav[pid].time_s, nav[pid].enu_m)
                    if unit:
                        raise InputError(f.path, unit)
                odo[pid] = data
                notes.extend([*data.notes, odometer_note(data)])
        except InputProblems as err:
            problems.extend(err.errors)
        except CoopprocError as err:
            problems.append(err)
    return imu, odo


def attach_decoded(
    imu: Mapping[str, ImuData],
    odometer: Mapping[str, OdometerData],
    path: Path,
    platforms: Mapping[str, Platform],
    problems: list[CoopprocError],
    notes: list[str],
) -> RawSensors:
    """IMU and odometer samples decoded from an MCAP file or a bag (checked by their
    readers), kept for the session's platforms; unknown platforms and a wrong body frame
    at rest are errors."""
    out_imu: dict[str, ImuData] = {}
    out_odo: dict[str, OdometerData] = {}
    for pid, data in sorted(imu.items()):
        if pid not in platforms:
            problems.append(_unknown(path, f"IMU samples ({data.source})", pid, sorted(platforms)))
            continue
        frame = "" if platforms[pid].imu_mounting_deg else frame_problem(data)
        if frame:
            problems.append(InputError(data.source, frame))
            continue
        out_imu[pid] = data
        notes.extend([*data.notes, imu_note(data)])
    for pid, odo in sorted(odometer.items()):
        if pid not in platforms:
            problems.append(_unknown(path, f"odometry ({odo.source})", pid, sorted(platforms)))
            continue
        out_odo[pid] = odo
        notes.append(odometer_note(odo))
    return out_imu, out_odo


def bag_imu(
    samples: Mapping[str, ImuSamples],
    path: Path,
    platforms: Mapping[str, Platform],
    problems: list[CoopprocError],
    notes: list[str],
) -> dict[str, ImuData]:
    """The ``sensor_msgs/msg/Imu`` topics of a bag, checked like ``imu_<ID>.csv``."""
    out: dict[str, ImuData] = {}
    for pid, s in sorted(samples.items()):
        if pid not in platforms:
            problems.append(_unknown(path, f"IMU topic {s.topic}", pid, sorted(platforms)))
            continue
        where = Locator(f"{path} {s.topic}", record=_message_namer(s.topic))
        values = np.column_stack([s.gyro_radps, s.accel_mps2])
        try:
            out[pid] = checked_imu(pid, where, s.time_s, values)
            frame = "" if platforms[pid].imu_mounting_deg else frame_problem(out[pid])
            if frame:
                del out[pid]
                raise InputError(where.path, frame)
        except CoopprocError as err:
            problems.append(err)
            continue
        notes.extend([*out[pid].notes, imu_note(out[pid])])
    return out


def _message_namer(topic: str) -> Callable[[int], str]:
    return lambda i: f"message {i + 1} on {topic}"


def sensor_notes(session: Session) -> list[str]:
    """One note per raw-sensor file of ``session``: what was read, or that it is not used."""
    out = []
    for f in session.sensor_files:
        pid = f.platform or ""
        if f.kind == "imu" and pid in session.imu:
            out.append(imu_note(session.imu[pid]))
        elif f.kind == "odo" and pid in session.odometer:
            out.append(odometer_note(session.odometer[pid]))
        else:
            out.append(sensor_note(f))
    return out


def write_imu_csv(imu: ImuData, path: Path) -> Path:
    """``imu_<ID>.csv`` in the rate form (the project's float format: 1e-6 rad/s, m/s^2)."""
    frame = pd.DataFrame({"time": imu.time_s})
    for k, col in enumerate(IMU_RATE_COLUMNS):
        frame[col] = (imu.gyro_radps if k < 3 else imu.accel_mps2)[:, k % 3]
    return write_csv(frame, path)


def write_odo_csv(odo: OdometerData, path: Path) -> Path:
    """``odo_<ID>.csv``: ``time, speed`` (wheel data are written as their forward speed)."""
    return write_csv(pd.DataFrame({"time": odo.time_s, "speed": odo.speed_mps}), path)
