"""The aiding of the INS engine as arrays (coopproc.ins.engine): ranges to known points,
loosely coupled positions, odometer speed, NHC and zero-velocity options, and how they
are tied to the IMU samples (:class:`coopproc.ins.loop.EventPlan`; docs/methods-ins.md,
"Engine")."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coopproc.frames import enu2geodetic
from coopproc.ins.loop import POSITION, RANGE, SPEED, EventPlan
from coopproc.model import FloatArray
from coopproc.sensors import ImuData

__all__ = [
    "InsAiding",
    "PositionObs",
    "RangeObs",
    "SpeedObs",
    "build_plan",
    "rad_llh",
    "static_mask",
]


def _arr(v: object, shape: tuple[int, ...] | None = None) -> FloatArray:
    a = np.asarray(v, dtype=np.float64)
    return np.broadcast_to(a, shape).copy() if shape is not None else a


@dataclass(frozen=True, eq=False)
class RangeObs:
    """Ranges from the UWB antenna to known points: ``time_s`` (n,) sorted, ``point_enu``
    (n, 3) the point in the session ENU frame, ``range_m``, ``sigma_m`` (n,); ``lever_b``
    the antenna in the body frame (m, from the IMU)."""

    time_s: FloatArray
    point_enu: FloatArray
    range_m: FloatArray
    sigma_m: FloatArray
    lever_b: FloatArray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class PositionObs:
    """Loosely coupled positions of the antenna at ``lever_b`` (GNSS, UWB least squares):
    ``time_s`` (n,) sorted, ``enu_m`` (n, 3), ``sigma_m`` (n, 3) per axis (E, N, U)."""

    time_s: FloatArray
    enu_m: FloatArray
    sigma_m: FloatArray
    lever_b: FloatArray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class SpeedObs:
    """Odometer forward speed of the point at ``lever_b``: ``time_s``, ``speed_mps``,
    ``sigma_mps`` (n,)."""

    time_s: FloatArray
    speed_mps: FloatArray
    sigma_mps: FloatArray
    lever_b: FloatArray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class InsAiding:
    """Everything that aids the INS. ``nhc``: non-holonomic constraints every
    ``nhc_every_s`` with 1-sigma (lateral, vertical) m/s at the constraint point
    ``nhc_lever_b``; ``zupt``: zero-velocity updates every ``zupt_every_s`` while the IMU
    (and the odometer, when given) says the platform is at rest (:func:`static_mask`);
    ``robust``: IGG-III (k0, k1) on range, position and speed innovations, or None."""

    ranges: RangeObs | None = None
    positions: PositionObs | None = None
    speed: SpeedObs | None = None
    nhc: bool = False
    nhc_sigma_mps: tuple[float, float] = (0.1, 0.1)
    nhc_lever_b: FloatArray = field(default_factory=lambda: np.zeros(3))
    nhc_every_s: float = 0.1
    zupt: bool = False
    zupt_sigma_mps: float = 0.01
    zupt_every_s: float = 0.1
    robust: tuple[float, float] | None = None


def static_mask(
    imu: ImuData,
    speed: SpeedObs | None = None,
    window_s: float = 0.5,
    accel_std: float = 0.05,
    gyro_max: float = 0.02,
    speed_max: float = 0.02,
) -> np.ndarray:
    """Per IMU sample: at rest. Windows of ``window_s``: |f| scatters less than
    ``accel_std`` m/s^2 around a mean within 2 % of 9.8, and the mean |omega| is below
    ``gyro_max`` rad/s; with an odometer also |speed| <= ``speed_max`` (the nearest
    sample). Without an odometer a constant-velocity straight drive on a smooth road looks
    at rest to the IMU: zero-velocity updates are meant for platforms that stop."""
    t = imu.time_s
    win = np.floor((t - t[0]) / window_s).astype(np.int64)
    f = np.linalg.norm(imu.accel_mps2, axis=1)
    w = np.linalg.norm(imu.gyro_radps, axis=1)
    n_w = int(win[-1]) + 1
    cnt = np.bincount(win, minlength=n_w).astype(np.float64)
    f_mean = np.bincount(win, f, n_w) / cnt
    f_var = np.bincount(win, f * f, n_w) / cnt - f_mean**2
    w_mean = np.bincount(win, w, n_w) / cnt
    ok = (np.abs(f_mean - 9.8) < 0.02 * 9.8) & (f_var < accel_std**2) & (w_mean < gyro_max)
    static = ok[win]
    if speed is not None and speed.time_s.size:
        i = np.clip(np.searchsorted(speed.time_s, t), 0, speed.time_s.size - 1)
        j = np.clip(i - 1, 0, None)
        near = np.where(np.abs(speed.time_s[j] - t) < np.abs(speed.time_s[i] - t), j, i)
        static &= np.abs(speed.speed_mps[near]) <= speed_max
    return np.asarray(static, dtype=np.bool_)


def rad_llh(enu: FloatArray, origin: tuple[float, float, float]) -> FloatArray:
    llh = enu2geodetic(enu, origin)
    return np.column_stack([np.radians(llh[:, 0]), np.radians(llh[:, 1]), llh[:, 2]])


def build_plan(
    t: FloatArray, aiding: InsAiding, cov_every: int, origin: tuple[float, float, float],
    static: np.ndarray,
) -> EventPlan:  # fmt: skip
    """Every measurement at its nearest IMU sample (samples 1..K-1), sorted; the
    propagation epochs: every ``cov_every`` samples, every aided sample, the last."""
    kinds: list[FloatArray] = []
    times: list[FloatArray] = []
    rows: list[FloatArray] = []
    levers = np.zeros((3, 3))

    def add(kind: int, tm: FloatArray, d: FloatArray) -> None:
        kinds.append(np.full(tm.size, kind))
        times.append(np.asarray(tm, dtype=np.float64))
        rows.append(d)

    if aiding.ranges is not None and aiding.ranges.time_s.size:
        r = aiding.ranges
        d = np.column_stack([rad_llh(r.point_enu, origin), r.range_m, r.sigma_m, 0 * r.range_m])
        add(RANGE, r.time_s, d)
        levers[RANGE] = _arr(r.lever_b, (3,))
    if aiding.positions is not None and aiding.positions.time_s.size:
        p = aiding.positions
        d = np.column_stack([rad_llh(p.enu_m, origin), _arr(p.sigma_m, p.enu_m.shape)])
        add(POSITION, p.time_s, d)
        levers[POSITION] = _arr(p.lever_b, (3,))
    if aiding.speed is not None and aiding.speed.time_s.size:
        s = aiding.speed
        d = np.zeros((s.time_s.size, 6))
        d[:, 0], d[:, 1] = s.speed_mps, s.sigma_mps
        add(SPEED, s.time_s, d)
        levers[SPEED] = _arr(s.lever_b, (3,))
    kind = np.concatenate(kinds).astype(np.int64) if kinds else np.zeros(0, np.int64)
    tm = np.concatenate(times) if times else np.zeros(0)
    data = np.concatenate(rows) if rows else np.zeros((0, 6))
    inside = (tm >= t[0]) & (tm <= t[-1])
    kind, tm, data = kind[inside], tm[inside], data[inside]
    i = np.clip(np.searchsorted(t, tm), 1, t.size - 1)
    k = np.where((i > 1) & (tm - t[i - 1] < t[i] - tm), i - 1, i).astype(np.int64)
    order = np.lexsort((tm, kind, k))
    kind, k, tm, data = kind[order], k[order], tm[order], data[order]
    dt_imu = float(np.median(np.diff(t)))
    nhc_every = max(1, round(aiding.nhc_every_s / dt_imu)) if aiding.nhc else 0
    zupt_every = max(1, round(aiding.zupt_every_s / dt_imu)) if aiding.zupt else 0
    idx = np.arange(t.size)
    is_epoch = (idx % max(cov_every, 1) == 0) | (idx == t.size - 1)
    is_epoch[k] = True
    if nhc_every:
        is_epoch |= idx % nhc_every == 0
    if zupt_every:
        is_epoch |= (idx % zupt_every == 0) & static
    robust = np.array(aiding.robust if aiding.robust is not None else (0.0, 0.0), np.float64)
    return EventPlan(
        kind, k, np.ascontiguousarray(tm - t[k]), np.ascontiguousarray(data), levers,
        nhc_every, _arr(aiding.nhc_sigma_mps, (2,)), _arr(aiding.nhc_lever_b, (3,)),
        zupt_every, float(aiding.zupt_sigma_mps), static, is_epoch, robust,
    )  # fmt: skip
