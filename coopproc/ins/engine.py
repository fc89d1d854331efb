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
from coopproc.frames import geodetic2enu
from coopproc.ins.aiding import (
    InsAiding,
    PositionObs,
    RangeObs,
    SpeedObs,
    build_plan,
    rad_llh,
    static_mask,
)
from coopproc.ins.align import Alignment, coarse_align
from coopproc.ins.earth import ecef_to_enu_matrix, normal_gravity
from coopproc.ins.errorstate import ErrorStateEkf, level_correlated
from coopproc.ins.loop import KIND_NAMES, EventPlan, ForwardRun
from coopproc.ins.mechanize import increments_from_rates, make_nav
from coopproc.ins.models import ImuFigures
from coopproc.ins.quat import quat_to_dcm
from coopproc.model import FloatArray, Session
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
    "session_origin",
    "static_mask",
]

#: The geodetic origin used when a session has none (lat deg, lon deg, h m): 45 deg N,
#: where normal gravity and the earth rate take their mid values (gravity differs by at
#: most 0.26 % from the poles' or the equator's; the horizontal earth rate by 29 %).
DEFAULT_ORIGIN_LLH = (45.0, 0.0, 0.0)


def session_origin(session: Session) -> tuple[float, float, float] | None:
    """The geodetic origin of a session's ENU frame for :class:`InsConfig`, or None when
    the session has none: no ``[frame] origin`` and no geodetic fix, for which the
    session reader leaves the placeholder (0, 0, 0) (the INS then uses
    :data:`DEFAULT_ORIGIN_LLH` rather than the equator's gravity and earth rate)."""
    origin = tuple(float(v) for v in session.origin_llh)
    if session.config.origin_llh is None and origin == (0.0, 0.0, 0.0):
        return None
    return origin  # type: ignore[return-value]


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
    ``att_deg`` (roll, pitch, yaw; yaw counter-clockwise from east), and the 1-sigmas of
    the last propagation epoch: ``sigma_enu`` (m), ``sigma_vel`` (m/s, ENU),
    ``sigma_att_deg`` (roll, pitch, yaw: the ENU attitude errors psi_E, psi_N turned into
    the body's forward and left axes by the yaw (their correlation left out), yaw = psi_U)."""

    enu_m: FloatArray
    vel_enu: FloatArray
    att_deg: FloatArray
    sigma_enu: FloatArray
    sigma_vel: FloatArray
    sigma_att_deg: FloatArray


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
    return al, np.asarray(start, dtype=np.float64).reshape(3)


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


def _track(run_nav: FloatArray, var: FloatArray, origin: tuple[float, float, float]) -> InsTrack:
    """Nav arrays (lat, lon rad) to the session frame: ENU position at the origin, the
    velocity rotated from the local-level frame at each position to the origin's; ``var``
    (K, 9) the held position, velocity and attitude-error variances."""
    llh = np.column_stack([np.degrees(run_nav[:, 0]), np.degrees(run_nav[:, 1]), run_nav[:, 2]])
    enu = geodetic2enu(llh, origin)
    lat, lon = run_nav[:, 0], run_nav[:, 1]
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    ve, vn, vu = run_nav[:, 3], run_nav[:, 4], run_nav[:, 5]
    ecef = np.column_stack([-so * ve - sl * co * vn + cl * co * vu,
                            co * ve - sl * so * vn + cl * so * vu,
                            cl * vn + sl * vu])  # fmt: skip
    c0 = ecef_to_enu_matrix(np.radians(origin[0]), np.radians(origin[1]))
    euler = _euler(run_nav[:, 6:10])
    sd = np.sqrt(np.maximum(var, 0.0))
    cy, sy = np.cos(euler[:, 2]), np.sin(euler[:, 2])
    ve_, vn_ = var[:, 6], var[:, 7]
    sig_att = np.column_stack([np.sqrt(np.maximum(cy * cy * ve_ + sy * sy * vn_, 0.0)),
                               np.sqrt(np.maximum(sy * sy * ve_ + cy * cy * vn_, 0.0)),
                               sd[:, 8]])  # fmt: skip
    # the velocity sigmas are those of the local-level frame (the rotation to the origin's
    # frame is below a milliradian over a session's extent)
    return InsTrack(enu, ecef @ c0.T, np.degrees(euler), sd[:, 0:3], sd[:, 3:6],
                    np.degrees(sig_att))  # fmt: skip


def _held_variance(run: ForwardRun, p_diag: FloatArray, k_n: int) -> FloatArray:
    """(K, 9) position, velocity and attitude-error variances, each sample holding its
    last propagation epoch's (``p_diag`` (J, n) the covariance diagonal per epoch)."""
    j = np.searchsorted(run.epoch_k, np.arange(k_n), side="right") - 1
    return p_diag[j, 0:9]


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
    llh0 = rad_llh(start[None, :], origin)[0]
    v0 = np.asarray(config.start_vel_enu, dtype=np.float64).reshape(3)
    nav0 = make_nav(llh0[0], llh0[1], llh0[2], v0, al.roll, al.pitch, al.yaw)
    static = static_mask(imu, aiding.speed) if aiding.zupt else np.zeros(t.size, np.bool_)
    plan = build_plan(t, aiding, config.cov_every, origin, static)
    ekf = ErrorStateEkf.start(
        config.figures, np.full(3, config.sigma_pos_m), np.full(3, config.sigma_vel_mps),
        np.array([al.sigma_level, al.sigma_level, al.sigma_yaw]), config.scale_factors,
    )  # fmt: skip
    if al.static_samples > 1:
        g = normal_gravity(float(llh0[0]), float(llh0[2]))
        ekf.p = level_correlated(ekf.p, quat_to_dcm(nav0[6:10]), g)
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
