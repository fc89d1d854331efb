"""What the simulator knows and a real recording does not: the truth behind a session."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import pandas as pd

from coopproc.gnss.ephemeris import GpsEphemerides
from coopproc.gnss.rinex_write import ObsTable
from coopproc.model import Session, Trajectory
from coopproc.sim.params import SimParams

__all__ = [
    "DISTANCE_COLUMNS",
    "DR_ERROR_COLUMNS",
    "DR_PARAM_COLUMNS",
    "GNSS_CLOCK_COLUMNS",
    "GNSS_ERROR_COLUMNS",
    "GROSS_ERROR_COLUMNS",
    "IMU_ERROR_COLUMNS",
    "NAV_FAULT_COLUMNS",
    "NAV_FRAME_COLUMNS",
    "NLOS_TRUTH_COLUMNS",
    "SimulatedGnss",
    "Simulation",
    "Truth",
]

#: ``truth/distances.csv``: true distance at every written range epoch, and the range's
#: total error (range - distance) in the same row order as the session's ranges.
DISTANCE_COLUMNS: tuple[str, ...] = ("time", "pair", "distance", "error")
#: ``truth/nlos_events.csv``: start/end in the session time base; realized_mean = mean of
#: the errors actually added over the event's written epochs; epochs = their count.
NLOS_TRUTH_COLUMNS: tuple[str, ...] = (
    "pair",
    "start",
    "end",
    "nominal_mean",
    "realized_mean",
    "epochs",
)
GROSS_ERROR_COLUMNS: tuple[str, ...] = ("time", "pair", "error")
#: ``truth/dr_error.csv``: navigation solution minus truth, at whole seconds of the nav grid. For a
#: platform whose nav is in its own frame (single-auxiliary target) the error is taken
#: before that frame's shift and rotation, i.e. the dead-reckoning error itself.
DR_ERROR_COLUMNS: tuple[str, ...] = (
    "time",
    "platform",
    "error_east",
    "error_north",
    "error_up",
    "error_h",
)
#: ``truth/dr_params.csv``: the sensor errors each dead-reckoning platform drew.
DR_PARAM_COLUMNS: tuple[str, ...] = (
    "platform",
    "gyro_bias_dph",
    "odo_scale",
    "heading_init_deg",
    "init_east",
    "init_north",
    "init_up",
)
#: ``truth/nav_frames.csv``: nav frame -> session frame of platforms with their own frame:
#: session_en = R(rotation) nav_en + shift, rotation clockwise (a heading in the nav
#: frame plus ``rotation_deg`` is the true heading).
NAV_FRAME_COLUMNS: tuple[str, ...] = ("platform", "rotation_deg", "shift_east", "shift_north")
#: ``truth/nav_faults.csv`` (written only when there is a fault): one row per fault of a
#: platform's navigation, start/end in the session time base; ``fault`` and ``value``:
#: ``heading_drift`` (heading-rate error, deg/min, whole session), ``odo_scale`` (the
#: odometer scale fault, a fraction, whole session; dr_params.odo_scale is the total),
#: ``slip`` (odometer over-read fraction in [start, end]), ``nav_gap`` (no nav rows in
#: [start, end]; value = nav epochs missing).
NAV_FAULT_COLUMNS: tuple[str, ...] = ("platform", "fault", "start", "end", "value")
#: ``truth/imu_errors.csv`` (written only with ``imu_rate_hz`` > 0): the errors each
#: platform's simulated IMU drew (turn-on biases deg/h and mg, scale factors ppm) and the
#: odometer scale of its ``odo_<ID>.csv`` (coopproc.sim.imu).
IMU_ERROR_COLUMNS: tuple[str, ...] = (
    "platform",
    "grade",
    *(f"gyro_turn_on_{a}" for a in "xyz"),
    *(f"accel_turn_on_{a}" for a in "xyz"),
    *(f"gyro_scale_ppm_{a}" for a in "xyz"),
    *(f"accel_scale_ppm_{a}" for a in "xyz"),
    "odo_scale",
)

#: ``truth/gnss_clock.csv``: the receiver clock at every observation epoch, in metres
#: (c dt_r) and m/s (c dt_r'): seconds would not survive the files' 1e-6 float format.
GNSS_CLOCK_COLUMNS = ("time", "platform", "clock_bias_m", "clock_drift_mps")
#: ``truth/gnss_errors.csv``: the terms of every pseudorange written:
#: P = range + clock_bias - sat_clock + tropo + iono + multipath + noise (metres).
GNSS_ERROR_COLUMNS = (
    "time", "platform", "prn", "elevation_deg", "azimuth_deg", "cn0_dbhz", "range",
    "sat_clock", "tropo", "iono", "multipath", "noise",
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class Truth:
    """The known truth of a simulated session (all times in the session time base)."""

    #: True trajectories at the nav rate (time, east, north, up, heading), by platform.
    trajectories: Mapping[str, Trajectory]
    distances: pd.DataFrame  # DISTANCE_COLUMNS
    nlos_events: pd.DataFrame  # NLOS_TRUTH_COLUMNS
    gross_errors: pd.DataFrame  # GROSS_ERROR_COLUMNS
    dr_error: pd.DataFrame  # DR_ERROR_COLUMNS
    dr_params: pd.DataFrame  # DR_PARAM_COLUMNS
    nav_frames: pd.DataFrame  # NAV_FRAME_COLUMNS
    #: The effective parameters the session was made with.
    params: SimParams
    #: Navigation faults (NAV_FAULT_COLUMNS); empty for the fault-free scenarios.
    nav_faults: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(NAV_FAULT_COLUMNS))
    )
    #: The simulated IMUs' error draws (IMU_ERROR_COLUMNS); empty without imu_rate_hz.
    imu_errors: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(IMU_ERROR_COLUMNS))
    )


@dataclass(frozen=True, eq=False)
class SimulatedGnss:
    """Simulated observations per platform, the ephemerides flown, and their truth."""

    observations: Mapping[str, ObsTable]
    ephemerides: GpsEphemerides
    rinex_version: int
    clock: pd.DataFrame  # GNSS_CLOCK_COLUMNS
    errors: pd.DataFrame  # GNSS_ERROR_COLUMNS


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated session and its truth."""

    scenario: str
    seed: int
    session: Session
    truth: Truth
    #: Simulated GNSS observations and their truth (``gnss_obs``; coopproc.sim.gnss_obs).
    gnss: SimulatedGnss | None = None
