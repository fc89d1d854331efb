"""The INS engine in array form (issue 12): raw IMU samples and aiding measurements in,
the INS solution in the session's ENU frame out, forward-filtered and RTS-smoothed
(docs/methods-ins.md, "Engine").

``run_ins(imu, aiding, config)`` aligns, ties every aiding measurement to an IMU sample
(:class:`coopproc.ins.loop.EventPlan`), runs the closed-loop error-state filter (the
compiled :func:`coopproc.ins.kernels.forward`, or the plain
:func:`coopproc.ins.loop.run_events`), optionally the RTS smoother over the full error
state (:mod:`coopproc.ins.smoother`), and converts the solution to the session frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from coopproc.errors import StageError
from coopproc.frames import enu2geodetic, geodetic2enu
from coopproc.ins.align import Alignment, coarse_align
from coopproc.ins.earth import ecef_to_enu_matrix
from coopproc.ins.errorstate import ErrorStateEkf
from coopproc.ins.loop import KIND_NAMES, POSITION, RANGE, SPEED, EventPlan, ForwardRun
from coopproc.ins.mechanize import increments_from_rates, make_nav
from coopproc.ins.models import ImuFigures
from coopproc.model import FloatArray
from coopproc.sensors import ImuData

__all__ = [
    "DEFAULT_ORIGIN_LLH",
    "InnovationStats",
    "InsAiding",
    "InsConfig",
    "InsResult",
    "InsTrack",
    "PositionObs",
    "Prepared",
    "RangeObs",
    "SpeedObs",
    "prepare",
    "run_forward",
    "run_ins",
    "static_mask",
]

#: The geodetic origin used when a session has none (lat deg, lon deg, h m): 45 deg N,
#: where normal gravity and the earth rate take their mid values (gravity differs by at
#: most 0.26 % from the poles' or the equator's; the horizontal earth rate by 29 %).
DEFAULT_ORIGIN_LLH = (45.0, 0.0, 0.0)


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


@dataclass(frozen=True, eq=False)
class InsConfig:
    """How to run the INS. ``origin_llh`` (lat deg, lon deg, h m) of the session's ENU
    frame, None: :data:`DEFAULT_ORIGIN_LLH`. ``alignment`` None: coarse alignment from the
    static start (heading from the first motion of ``aiding.positions``). ``start_enu``
    None: the first aiding position. ``cov_every``: covariance propagation every that many
    IMU samples (and at every aided sample). ``engine``: the compiled loop or the plain
    numpy/Python reference."""

    figures: ImuFigures
    origin_llh: tuple[float, float, float] | None = None
    alignment: Alignment | None = None
    start_enu: FloatArray | None = None
    start_vel_enu: FloatArray = field(default_factory=lambda: np.zeros(3))
    sigma_pos_m: float = 1.0
    sigma_vel_mps: float = 0.1
    scale_factors: bool = False
    cov_every: int = 10
    smooth: bool = False
    engine: Literal["compiled", "plain"] = "compiled"


@dataclass(frozen=True, eq=False)
class InsTrack:
    """One INS solution per IMU sample, session ENU frame: ``enu_m``, ``vel_enu`` (m/s),
    ``att_deg`` (roll, pitch, yaw; yaw counter-clockwise from east), ``sigma_enu`` (m,
    the 1-sigma position of the last propagation epoch)."""

    enu_m: FloatArray
    vel_enu: FloatArray
    att_deg: FloatArray
    sigma_enu: FloatArray


@dataclass(frozen=True)
class InnovationStats:
    """One aiding kind's scalar innovations: how many, accepted (IGG-III factor 1),
    down-weighted, rejected, and the RMS of the innovations normalized by their
    predicted sigma sqrt(H P H^T + R) (about 1 when the filter is consistent)."""

    kind: str
    count: int
    accepted: int
    downweighted: int
    rejected: int
    nis_rms: float


@dataclass(frozen=True, eq=False)
class InsResult:
    """``forward`` the closed-loop filter, ``smoothed`` the RTS solution (None unless
    ``config.smooth``), ``stats`` one row per aiding kind used, ``alignment`` the start."""

    time_s: FloatArray
    forward: InsTrack
    smoothed: InsTrack | None
    stats: tuple[InnovationStats, ...]
    alignment: Alignment
    origin_llh: tuple[float, float, float]

    @property
    def best(self) -> InsTrack:
        """The smoothed solution when there is one, else the forward one."""
        return self.smoothed if self.smoothed is not None else self.forward


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


def _rad_llh(enu: FloatArray, origin: tuple[float, float, float]) -> FloatArray:
    llh = enu2geodetic(enu, origin)
    return np.column_stack([np.radians(llh[:, 0]), np.radians(llh[:, 1]), llh[:, 2]])


def _plan(
    t: FloatArray, aiding: InsAiding, cfg: InsConfig, origin: tuple[float, float, float],
    static: np.ndarray,
) -> EventPlan:  # fmt: skip
    """Every measurement at its nearest IMU sample (samples 1..K-1), sorted."""
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
        d = np.column_stack([_rad_llh(r.point_enu, origin), r.range_m, r.sigma_m, 0 * r.range_m])
        add(RANGE, r.time_s, d)
        levers[RANGE] = _arr(r.lever_b, (3,))
    if aiding.positions is not None and aiding.positions.time_s.size:
        p = aiding.positions
        d = np.column_stack([_rad_llh(p.enu_m, origin), _arr(p.sigma_m, p.enu_m.shape)])
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
    is_epoch = (idx % max(cfg.cov_every, 1) == 0) | (idx == t.size - 1)
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


def _start(
    imu: ImuData, aiding: InsAiding, cfg: InsConfig, lat: float
) -> tuple[Alignment, FloatArray]:
    """The alignment and the start position (session ENU)."""
    pos = aiding.positions
    start = cfg.start_enu
    if start is None:
        if pos is None or pos.time_s.size == 0:
            raise StageError(
                f"INS of {imu.platform}: no start position (give InsConfig.start_enu or "
                "loosely coupled positions)"
            )
        start = pos.enu_m[
            int(np.searchsorted(pos.time_s, imu.time_s[0]).clip(0, pos.time_s.size - 1))
        ]
    al = cfg.alignment
    if al is None:
        motion = (pos.time_s, pos.enu_m) if pos is not None and pos.time_s.size > 1 else None
        al = coarse_align(imu.time_s, imu.gyro_radps, imu.accel_mps2, lat, cfg.figures,
                          motion=motion)  # fmt: skip
    return al, _arr(start, (3,))


def _euler(q: FloatArray) -> FloatArray:
    """(K, 3) roll, pitch, yaw (rad) of (K, 4) quaternions: quat.quat_to_euler, vectorized."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    c21 = 2.0 * (y * z + w * x)
    c22 = w * w - x * x - y * y + z * z
    c20 = 2.0 * (x * z - w * y)
    c10 = 2.0 * (x * y + w * z)
    c00 = w * w + x * x - y * y - z * z
    return np.column_stack(
        [np.arctan2(c21, c22), np.arcsin(np.clip(-c20, -1.0, 1.0)), np.arctan2(c10, c00)]
    )


def _track(
    run_nav: FloatArray, var_pos: FloatArray, origin: tuple[float, float, float]
) -> InsTrack:
    """Nav arrays (lat, lon rad) to the session frame: ENU position at the origin, the
    velocity rotated from the local-level frame at each position to the origin's."""
    llh = np.column_stack([np.degrees(run_nav[:, 0]), np.degrees(run_nav[:, 1]), run_nav[:, 2]])
    enu = geodetic2enu(llh, origin)
    lat, lon = run_nav[:, 0], run_nav[:, 1]
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    ve, vn, vu = run_nav[:, 3], run_nav[:, 4], run_nav[:, 5]
    ecef = np.column_stack([-so * ve - sl * co * vn + cl * co * vu,
                            co * ve - sl * so * vn + cl * so * vu,
                            cl * vn + sl * vu])  # fmt: skip
    c0 = ecef_to_enu_matrix(np.radians(origin[0]), np.radians(origin[1]))
    att = np.degrees(_euler(run_nav[:, 6:10]))
    return InsTrack(enu, ecef @ c0.T, att, np.sqrt(np.maximum(var_pos, 0.0)))


def _held_variance(run: ForwardRun, p_diag: FloatArray, k_n: int) -> FloatArray:
    """(K, 3) position variances, each sample holding its last propagation epoch's
    (``p_diag`` (J, n) the covariance diagonal per epoch)."""
    j = np.searchsorted(run.epoch_k, np.arange(k_n), side="right") - 1
    return p_diag[j, 0:3]


def _stats(run: ForwardRun) -> tuple[InnovationStats, ...]:
    out = []
    for i, name in enumerate(KIND_NAMES):
        c = run.stats[i]
        if c[0] > 0:
            out.append(InnovationStats(name, int(c[0]), int(c[1]), int(c[2]), int(c[3]),
                                       float(np.sqrt(c[4] / c[0]))))  # fmt: skip
    return tuple(out)


@dataclass(frozen=True, eq=False)
class Prepared:
    """The inputs of the forward loops (:func:`prepare`): IMU increments, the start nav,
    the filter's start (P0, figures) and the aiding plan."""

    time_s: FloatArray
    dtheta: FloatArray
    dvel: FloatArray
    nav0: FloatArray
    ekf: ErrorStateEkf
    plan: EventPlan
    alignment: Alignment
    origin_llh: tuple[float, float, float]


def prepare(imu: ImuData, aiding: InsAiding, config: InsConfig) -> Prepared:
    """Align, build the start nav and P0, tie the aiding to the IMU samples."""
    origin = config.origin_llh if config.origin_llh is not None else DEFAULT_ORIGIN_LLH
    t = np.asarray(imu.time_s, dtype=np.float64)
    if t.size < 3:
        raise StageError(f"INS of {imu.platform}: {t.size} IMU samples, at least 3 needed")
    al, start = _start(imu, aiding, config, np.radians(origin[0]))
    _, dth, dv = increments_from_rates(t, imu.gyro_radps, imu.accel_mps2)
    llh0 = _rad_llh(start[None, :], origin)[0]
    v0 = _arr(config.start_vel_enu, (3,))
    nav0 = make_nav(llh0[0], llh0[1], llh0[2], v0, al.roll, al.pitch, al.yaw)
    static = static_mask(imu, aiding.speed) if aiding.zupt else np.zeros(t.size, np.bool_)
    plan = _plan(t, aiding, config, origin, static)
    ekf = ErrorStateEkf.start(
        config.figures, np.full(3, config.sigma_pos_m), np.full(3, config.sigma_vel_mps),
        np.array([al.sigma_level, al.sigma_level, al.sigma_yaw]), config.scale_factors,
    )  # fmt: skip
    return Prepared(t, dth, dv, nav0, ekf, plan, al, origin)


def run_forward(
    prep: Prepared,
    engine: Literal["compiled", "plain"] = "compiled",
    progress: Callable[[float], None] | None = None,
) -> ForwardRun:
    """The forward filter of a :class:`Prepared` run (P0 copied: repeatable)."""
    ekf = ErrorStateEkf(prep.ekf.noise, prep.ekf.p.copy())
    if engine == "plain":
        from coopproc.ins.loop import run_events

        return run_events(prep.time_s, prep.dtheta, prep.dvel, prep.nav0, ekf, prep.plan,
                          progress)  # fmt: skip
    from coopproc.ins.kernels import forward

    return forward(prep.time_s, prep.dtheta, prep.dvel, prep.nav0, ekf, prep.plan, progress)


def run_ins(
    imu: ImuData,
    aiding: InsAiding,
    config: InsConfig,
    progress: Callable[[float], None] | None = None,
) -> InsResult:
    """The INS solution of one platform (see the module docstring); ``progress(fraction)``
    is called now and then during the forward pass."""
    prep = prepare(imu, aiding, config)
    t, origin = prep.time_s, prep.origin_llh
    run = run_forward(prep, config.engine, progress)
    p_diag = np.diagonal(run.p_filt, axis1=1, axis2=2)
    forward_track = _track(run.nav, _held_variance(run, p_diag, t.size), origin)
    smoothed = None
    if config.smooth:
        from coopproc.ins.smoother import smooth

        sm = smooth(t, run, config.figures)
        smoothed = _track(sm.nav, _held_variance(run, sm.p_diag, t.size), origin)
    return InsResult(t, forward_track, smoothed, _stats(run), prep.alignment, origin)
