"""Raw IMU and odometer samples consistent with each simulated trajectory (issue 12 item 6).

Off unless ``imu_rate_hz > 0`` (then every existing scenario writes the same files as
before plus ``imu_<ID>.csv`` and ``odo_<ID>.csv``). For each moving platform:

- **Trajectory**: a cubic spline (not-a-knot) through the true positions at the nav rate
  gives position, velocity and acceleration at the IMU rate (the IMU's truth is this
  spline; it passes through every true epoch).
- **Attitude**: yaw = the course of the horizontal velocity (counter-clockwise from east,
  ENU), pitch = the path's slope (atan2(v_up, v_horizontal)), roll = 0 (the body stays
  level across the track). Below 0.02 m/s horizontal speed the attitude is held.
  Body frame x forward, y left, z up: C_b^n = Rz(yaw) Ry(-pitch).
- **Gyros**: omega_ib^b = (sin(pitch) yaw', -pitch', cos(pitch) yaw') + C_n^b omega_ie^n,
  omega_ie^n = Omega (0, cos lat, sin lat) at the session origin's latitude (with
  ``imu_earth_rate``; the transport rate, v / R < 1e-6 rad/s here, is left out).
- **Accelerometers**: f^b = C_n^b (a^n + 2 omega_ie^n x v^n + (0, 0, gamma)), gamma the
  normal gravity (Somigliana) at the origin latitude minus 3.086e-6 /s^2 per metre of
  height (the Coriolis term only with ``imu_earth_rate``).
- **Errors** of the grade (:data:`coopproc.sensors.IMU_GRADE_FIGURES`), per axis:
  measured = (1 + s) true + b_on + b_gm(t) + n, with s ~ N(0, scale_ppm), constant
  turn-on bias b_on, first-order Gauss-Markov bias instability b_gm (steady-state sigma
  = the grade's figure, correlation time tau) and white noise n of sigma ARW sqrt(rate).
- **Odometer** at ``odo_rate_hz``: forward speed v . x_b times (1 + k), k = the
  platform's dead-reckoning ``odo_scale`` draw (truth/dr_params.csv; a new
  N(0, odo_scale_sigma) draw for platforms without dead reckoning), plus white noise of
  the ``odo_noise_m`` distance noise: sigma_v = odo_noise_m sqrt(|v| dt) / dt.

The draws are in ``truth/imu_errors.csv``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline

from coopproc.frames import EARTH_RATE_RADPS
from coopproc.model import FloatArray, ImuNoise, Trajectory
from coopproc.sensors import IMU_GRADE_FIGURES, ImuData, ImuGrade, OdometerData
from coopproc.sim.params import SimParams
from coopproc.sim.scenario_types import named_rng
from coopproc.sim.truth import IMU_ERROR_COLUMNS, Simulation

__all__ = [
    "ImuTruth",
    "add_raw_sensors",
    "imu_errors",
    "imu_truth",
    "normal_gravity",
    "odometer_samples",
]

#: Below this horizontal speed the attitude is held, m/s.
_HOLD_SPEED_MPS = 0.02


def normal_gravity(lat_deg: float, height_m: FloatArray | float) -> FloatArray:
    """Normal gravity (Somigliana, WGS-84) at ``lat_deg``, minus 3.086e-6 /s^2 per metre."""
    s2 = np.sin(np.radians(lat_deg)) ** 2
    # 0.00669437999013 is e^2 rounded to 14 digits (frames.WGS84_E2 differs by 1e-16):
    # kept so that the simulated IMU samples stay bit-identical (issue 34).
    g0 = 9.7803253359 * (1 + 0.00193185265241 * s2) / np.sqrt(1 - 0.00669437999013 * s2)
    return np.asarray(g0 - 3.086e-6 * np.asarray(height_m, dtype=np.float64))


@dataclass(frozen=True, eq=False)
class ImuTruth:
    """Error-free IMU samples and the attitude behind them (body x fwd, y left, z up)."""

    time_s: FloatArray
    gyro_radps: FloatArray  # (n, 3)
    accel_mps2: FloatArray  # (n, 3)
    enu_m: FloatArray  # (n, 3) the spline's positions
    vel_enu_mps: FloatArray  # (n, 3)
    yaw_rad: FloatArray  # counter-clockwise from east
    pitch_rad: FloatArray


def _held(angle: FloatArray, moving: np.ndarray) -> FloatArray:
    """``angle`` where moving, else the last moving value (the first one before it)."""
    if not moving.any():
        return np.zeros_like(angle)
    idx = np.where(moving, np.arange(angle.size), 0)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(moving))
    idx[:first] = first
    return angle[idx]


def imu_truth(
    truth: Trajectory,
    time_s: FloatArray,
    origin_llh: tuple[float, float, float],
    earth: bool,
    body: str = "vehicle",
) -> ImuTruth:
    """The error-free gyro and accelerometer samples along ``truth`` at ``time_s``;
    ``body`` "multirotor": tilted by its thrust, yawed by ``truth.heading_deg``
    (:mod:`coopproc.sim.multirotor`)."""
    spline = CubicSpline(truth.time_s, truth.enu_m, axis=0)
    if body == "multirotor":
        return _multirotor_truth(spline, truth, time_s, origin_llh, earth)
    p, v, a = spline(time_s), spline(time_s, 1), spline(time_s, 2)
    vh = np.hypot(v[:, 0], v[:, 1])
    moving = vh > _HOLD_SPEED_MPS
    safe = np.where(moving, vh, 1.0)
    yaw = _held(np.unwrap(np.arctan2(v[:, 1], v[:, 0])), moving)
    yaw_rate = np.where(moving, (v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / safe**2, 0.0)
    pitch = _held(np.arctan2(v[:, 2], vh), moving)
    ah = (v[:, 0] * a[:, 0] + v[:, 1] * a[:, 1]) / safe  # d|v_h|/dt
    pitch_rate = np.where(moving, (vh * a[:, 2] - v[:, 2] * ah) / (safe**2 + v[:, 2] ** 2), 0.0)
    gyro = np.column_stack(
        (np.sin(pitch) * yaw_rate, -pitch_rate, np.cos(pitch) * yaw_rate)
    ).astype(np.float64)
    lat = np.radians(origin_llh[0])
    w_ie = EARTH_RATE_RADPS * np.array([0.0, np.cos(lat), np.sin(lat)])
    f_n = a.copy()
    f_n[:, 2] += normal_gravity(origin_llh[0], origin_llh[2] + p[:, 2])
    if earth:
        f_n += 2.0 * np.cross(w_ie, v)
    gyro_ie = to_body(np.broadcast_to(w_ie, p.shape), yaw, pitch) if earth else 0.0
    return ImuTruth(
        time_s=time_s,
        gyro_radps=gyro + gyro_ie,
        accel_mps2=to_body(f_n, yaw, pitch),
        enu_m=p,
        vel_enu_mps=v,
        yaw_rad=yaw,
        pitch_rad=pitch,
    )


def _multirotor_truth(
    spline: CubicSpline,
    truth: Trajectory,
    time_s: FloatArray,
    origin_llh: tuple[float, float, float],
    earth: bool,
) -> ImuTruth:
    from coopproc.sim.multirotor import multirotor_imu

    assert truth.heading_deg is not None
    yaw = CubicSpline(truth.time_s, np.unwrap(np.radians(90.0 - truth.heading_deg)))
    lat = np.radians(origin_llh[0])
    w_ie = EARTH_RATE_RADPS * np.array([0.0, np.cos(lat), np.sin(lat)]) if earth else None
    dt = float(np.median(np.diff(time_s))) if time_s.size > 1 else 0.0
    gravity = lambda up: normal_gravity(origin_llh[0], origin_llh[2] + up)  # noqa: E731
    gyro, accel, c = multirotor_imu(spline, yaw, time_s, gravity, w_ie, dt)
    return ImuTruth(
        time_s=time_s,
        gyro_radps=gyro,
        accel_mps2=accel,
        enu_m=spline(time_s),
        vel_enu_mps=spline(time_s, 1),
        yaw_rad=np.arctan2(c[:, 1, 0], c[:, 0, 0]),
        pitch_rad=np.arcsin(np.clip(c[:, 2, 0], -1.0, 1.0)),
    )


def to_body(vec_n: FloatArray, yaw: FloatArray, pitch: FloatArray) -> FloatArray:
    """C_n^b vec: ENU vectors into the body frame (C_b^n = Rz(yaw) Ry(-pitch))."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    # Rz(-yaw): the vector in the yawed frame
    x = cy * vec_n[:, 0] + sy * vec_n[:, 1]
    y = -sy * vec_n[:, 0] + cy * vec_n[:, 1]
    z = vec_n[:, 2]
    # Ry(pitch) (the transpose of Ry(-pitch))
    return np.column_stack((cp * x + sp * z, y, -sp * x + cp * z)).astype(np.float64)


def _gauss_markov(
    rng: np.random.Generator, n: int, sigma: float, tau: float, dt: float
) -> FloatArray:
    """(n, 3) first-order Gauss-Markov with steady-state ``sigma``, correlation time ``tau``."""
    phi = np.exp(-dt / tau)
    drive = rng.normal(0.0, sigma * np.sqrt(1.0 - phi**2), (n, 3))
    drive[0] = rng.normal(0.0, sigma, 3)
    from scipy.signal import lfilter

    return np.asarray(lfilter([1.0], [1.0, -phi], drive, axis=0), dtype=np.float64)


def imu_errors(
    ideal: ImuTruth, grade: ImuGrade, rate_hz: float, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray, dict[str, float]]:
    """The measured gyro (rad/s) and accel (m/s^2) with the grade's errors, and the draws."""
    n, dt = ideal.time_s.size, 1.0 / rate_hz
    deg_h, mg = np.radians(1.0) / 3600.0, 9.80665e-3
    out, draws = [], {}
    for sensor, true, white, bias, on in (
        ("gyro", ideal.gyro_radps, np.radians(grade.gyro_arw), grade.gyro_bias * deg_h,
         grade.gyro_turn_on * deg_h),
        ("accel", ideal.accel_mps2, grade.accel_vrw, grade.accel_bias * mg,
         grade.accel_turn_on * mg),
    ):  # fmt: skip
        scale = rng.normal(0.0, grade.scale_ppm * 1e-6, 3)
        turn_on = rng.normal(0.0, on, 3)
        gm = _gauss_markov(rng, n, bias, grade.correlation_time_s, dt)
        noise = rng.normal(0.0, white * np.sqrt(rate_hz), (n, 3))
        out.append((1.0 + scale) * true + turn_on + gm + noise)
        unit = deg_h if sensor == "gyro" else mg
        for k, axis in enumerate("xyz"):
            draws[f"{sensor}_turn_on_{axis}"] = float(turn_on[k] / unit)
            draws[f"{sensor}_scale_ppm_{axis}"] = float(scale[k] * 1e6)
    return out[0], out[1], draws


def odometer_samples(
    truth: Trajectory, time_s: FloatArray, scale: float, noise_m: float, rng: np.random.Generator
) -> FloatArray:
    """Forward speed (m/s) along ``truth`` at ``time_s``, scaled by 1 + ``scale``, noisy."""
    spline = CubicSpline(truth.time_s, truth.enu_m, axis=0)
    v = spline(time_s, 1)
    vh = np.hypot(v[:, 0], v[:, 1])
    moving = vh > _HOLD_SPEED_MPS
    yaw = _held(np.arctan2(v[:, 1], v[:, 0]), moving)
    pitch = _held(np.arctan2(v[:, 2], vh), moving)
    forward = to_body(v, yaw, pitch)[:, 0]
    dt = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    sigma = noise_m * np.sqrt(np.abs(forward) * dt) / dt
    return np.asarray((1.0 + scale) * forward + rng.normal(0.0, 1.0, time_s.size) * sigma)


def _grid(start: float, duration: float, rate: float) -> FloatArray:
    n = int(np.floor(duration * rate + 1e-9)) + 1
    return np.round(start + np.arange(n) / rate, 9)


def add_raw_sensors(sim: Simulation) -> Simulation:
    """``sim`` with IMU and odometer samples of every moving platform in its session and
    their error draws in its truth (``imu_rate_hz`` > 0; else ``sim`` itself)."""
    p: SimParams = sim.truth.params
    if p.imu_rate_hz <= 0:
        return sim
    grade = IMU_GRADE_FIGURES[p.imu_grade]
    scales = dict(
        zip(sim.truth.dr_params["platform"], sim.truth.dr_params["odo_scale"], strict=True)
    )
    imu: dict[str, ImuData] = {}
    odo: dict[str, OdometerData] = {}
    rows = []
    for pid, truth in sorted(sim.truth.trajectories.items()):
        if sim.session.platforms[pid].role == "anchor":
            continue
        t0, t1 = truth.span_s
        t_imu = _grid(t0, t1 - t0, p.imu_rate_hz)
        ideal = imu_truth(truth, t_imu, sim.session.origin_llh, p.imu_earth_rate, p.imu_body)
        rng = named_rng(sim.seed, f"imu:{pid}")
        gyro, accel, draws = imu_errors(ideal, grade, p.imu_rate_hz, rng)
        imu[pid] = ImuData(pid, "simulated", t_imu, gyro, accel, "rate", 0.0)
        if p.imu_body == "multirotor":  # no wheels
            rows.append({"platform": pid, "grade": grade.name, **draws, "odo_scale": np.nan})
            continue
        odo_rng = named_rng(sim.seed, f"odo:{pid}")
        scale = float(scales.get(pid, odo_rng.normal(0.0, p.odo_scale_sigma)))
        t_odo = _grid(t0, t1 - t0, p.odo_rate_hz)
        speed = odometer_samples(truth, t_odo, scale, p.odo_noise_m, odo_rng)
        odo[pid] = OdometerData(pid, "simulated", t_odo, speed, "speed")
        rows.append({"platform": pid, "grade": grade.name, **draws, "odo_scale": scale})
    # session.toml declares what the files are: the grade drawn, and NHC (the simulated
    # vehicle has no lateral or vertical velocity: roll 0, yaw along the course, see
    # above; a multirotor: nhc = false)
    declared = ImuNoise(grade=grade.name)
    nhc = p.imu_body == "vehicle"  # a multirotor's body velocity has every direction
    platforms = {
        pid: dataclasses.replace(plat, nhc=nhc, imu=declared) if pid in imu else plat
        for pid, plat in sim.session.platforms.items()
    }
    session = dataclasses.replace(sim.session, imu=imu, odometer=odo, platforms=platforms)
    table = pd.DataFrame(rows, columns=list(IMU_ERROR_COLUMNS))
    known = dataclasses.replace(sim.truth, imu_errors=table)
    return dataclasses.replace(sim, session=session, truth=known)
