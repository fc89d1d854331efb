"""Paper 002's INS error states in the tightly coupled GPS/UWB filter (eq. 1-13).

A platform with an IMU runs :class:`InsTrack` in place of the constant-velocity
:class:`~coopproc.stages.gnss.tight_filter.CvTrack`: the same pseudorange, Doppler and
UWB rows and the same IGG-III factors (:mod:`coopproc.stages.gnss.tight_filter`), on
the state

``x = [dr (3), dv (3), psi (3), b_g (3), b_a (3), c dt_r, c dt_r']``

- ``dr .. b_a``: the INS engine's 15-state error model (:mod:`coopproc.ins.errorstate`,
  paper 002 eq. (1)-(5)), INS minus true, in the local-level ENU frame at the INS;
- the receiver clock bias and drift as full states (eq. (6)-(7), the two-state clock of
  the constant-velocity filter).

Time update (eq. (12)-(13)): the engine's compiled strapdown step
(:func:`coopproc.ins.mechanize.ins_step`, bias-compensated increments) from IMU sample to
IMU sample up to the update time; the covariance of the error states by the engine's
Phi and Q (:func:`coopproc.ins.propagation.phi_q`, ``propagate_cov``) every
``COV_EVERY`` samples and at every update; the clock block as in the CV filter. Closed
loop: after every update the error states are fed back into the nav
(:func:`~coopproc.ins.propagation.apply_correction_nb`) and the bias estimates, and reset
to zero.

Rows (innovation ``z - h(INS)``, so ``H = -dh/dx`` on the error states): with ``u`` the
unit vector receiver -> satellite (local ENU) and ``l`` the body lever arm IMU ->
antenna (``[platforms.X] gnss_lever_arm`` / ``uwb_lever_arm``, zero when not given),
pseudorange ``[u^T, 0, u^T [C l x], 0, 0, 1, 0]``; range rate ``[0, u^T, 0, 0, 0, 0, 1]``
(the lever arm's rotation rate left out); UWB range with ``e`` the unit vector from the
other end to the UWB antenna ``[-e^T, 0, -e^T [C l x], 0, 0, 0, 0]``. No NHC, odometer
or zero-velocity rows: paper 002's filter is GPS/UWB/INS.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numba
import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.estimation.process_models import cv_transition
from coopproc.gnss.tight import GnssEpochs, LocalFrame
from coopproc.ins.aiding import rad_llh
from coopproc.ins.align import Alignment
from coopproc.ins.earth import ecef_to_enu_matrix, llh_to_ecef, normal_gravity, radii
from coopproc.ins.errorstate import ErrorStateEkf, level_correlated
from coopproc.ins.mechanize import increments_from_rates, ins_step, make_nav
from coopproc.ins.models import ImuFigures
from coopproc.ins.propagation import apply_correction_nb, continuous_noise, phi_q, propagate_cov
from coopproc.ins.quat import quat_to_dcm, quat_to_euler, skew
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.sensors import ImuData
from coopproc.stages.gnss.tight_filter import CvTrack, TightOptions, clock_transition

__all__ = ["COV_EVERY", "InsTrack", "track_factory"]

#: covariance propagation every that many IMU samples (and at every update)
COV_EVERY = 10
_N = 15


@numba.njit(cache=True)
def _advance(
    t: FloatArray, dth_raw: FloatArray, dv_raw: FloatArray, k0: int, k1: int,
    nav: FloatArray, prev: FloatArray, sens: FloatArray, p: FloatArray, phi_tot: FloatArray,
    qc: FloatArray, tau: float, every: int,
) -> None:  # fmt: skip
    """Mechanize samples k0..k1-1 (in place: ``nav``, ``prev`` the previous compensated
    increments (6), ``p`` the 15-state covariance); ``phi_tot`` gets the product of the
    blocks' Phi (for the cross-covariance with the clock)."""
    n = p.shape[0]
    ein = np.zeros(17)
    dth = np.empty(3)
    dv = np.empty(3)
    tmp = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            phi_tot[i, j] = 1.0 if i == j else 0.0
    count = 0
    for k in range(k0, k1):
        dt = t[k] - t[k - 1]
        for i in range(3):
            dth[i] = dth_raw[k, i] - sens[i] * dt
            dv[i] = dv_raw[k, i] - sens[3 + i] * dt
        if count == 0:
            ein[0:10] = nav
        ins_step(nav, prev[0:3], prev[3:6], dth, dv, dt)
        for i in range(3):
            ein[10 + i] += dth[i]
            ein[13 + i] += dv[i]
        ein[16] += dt
        count += 1
        if count >= every or k == k1 - 1:
            phi, q = phi_q(ein, qc, tau, n)
            p[:, :] = propagate_cov(p, phi, q)
            for i in range(n):
                for j in range(n):
                    acc = 0.0
                    for m in range(n):
                        acc += phi[i, m] * phi_tot[m, j]
                    tmp[i, j] = acc
            phi_tot[:, :] = tmp
            ein[:] = 0.0
            count = 0
        prev[0:3] = dth
        prev[3:6] = dv


class InsTrack(CvTrack):
    """One platform's INS-coupled filter (module docstring)."""

    clock = _N

    def __init__(
        self,
        name: str,
        epochs: GnssEpochs,
        start_enu: FloatArray,
        frame: LocalFrame,
        imu: ImuData,
        figures: ImuFigures,
        alignment: Alignment,
        start_vel_enu: FloatArray,
        levers: tuple[FloatArray, FloatArray],
    ) -> None:
        super().__init__(name, epochs, start_enu)
        self.x = np.zeros(_N + 2)
        self.c = np.eye(_N + 2)
        self.frame = frame
        self.imu_t = np.ascontiguousarray(imu.time_s, dtype=np.float64)
        _, dth, dv = increments_from_rates(self.imu_t, imu.gyro_radps, imu.accel_mps2)
        self.dth, self.dv = np.ascontiguousarray(dth), np.ascontiguousarray(dv)
        self.figures = figures
        self.alignment = alignment
        self.start_enu = np.asarray(start_enu, dtype=np.float64).copy()
        self.start_vel = np.asarray(start_vel_enu, dtype=np.float64).copy()
        self.lever_gnss, self.lever_uwb = levers
        self.qc = continuous_noise(figures, _N)
        self.sens = np.zeros(6)
        self.prev = np.concatenate([self.dth[0], self.dv[0]])
        self.k = 0
        #: the time the nav holds (the last IMU sample, or later when coasting past the end)
        self.t_nav = float(self.imu_t[0])
        self.nav = self._nav_at(self.start_enu, self.start_vel)
        self._geometry()

    def _nav_at(self, enu: FloatArray, vel_enu: FloatArray) -> FloatArray:
        """A nav array at a session-ENU position with the alignment's attitude."""
        f = self.frame
        lat, lon, h = rad_llh(
            enu[None, :], (np.degrees(f.lat_rad), np.degrees(f.lon_rad), f.height_m)
        )[0]
        al = self.alignment
        return make_nav(lat, lon, h, vel_enu, al.roll, al.pitch, al.yaw)

    def _geometry(self) -> None:
        """The IMU in session ENU, the rotation local-level -> session ENU, C_b^n."""
        nav = self.nav
        self.rot = self.frame.rot @ ecef_to_enu_matrix(nav[0], nav[1]).T
        self.enu = self.frame.rot @ (llh_to_ecef(nav[0], nav[1], nav[2]) - self.frame.ecef0)
        self.cbn = quat_to_dcm(nav[6:10])

    def ready(self, t: float) -> bool:
        return bool(self.imu_t[0] <= t <= self.imu_t[-1])

    def _run(self, t: float, p: FloatArray) -> FloatArray:
        """Mechanize up to the last IMU sample at or before ``t``; the product of Phi."""
        k1 = int(np.searchsorted(self.imu_t, t, side="right"))
        phi_tot = np.eye(_N)
        if k1 > self.k + 1:
            _advance(self.imu_t, self.dth, self.dv, self.k + 1, k1, self.nav, self.prev,
                     self.sens, p, phi_tot, self.qc, float(self.figures.correlation_time),
                     COV_EVERY)  # fmt: skip
            self.k = k1 - 1
            self.t_nav = float(self.imu_t[self.k])
            self._geometry()
        return phi_tot

    def begin(self, t: float, clock_m: float, drift_mps: float, opt: TightOptions) -> None:
        """Free INS from the alignment to the first GPS epoch, then the start position
        (as the CV filter's, 30 m sigma), P0 of the engine (alignment, figures)."""
        self._run(t, np.zeros((_N, _N)))
        nav = self._nav_at(self.start_enu, self.nav[3:6])
        nav[6:10] = self.nav[6:10]
        self.nav = nav
        self._geometry()
        al = self.alignment
        ekf = ErrorStateEkf.start(
            self.figures, np.full(3, opt.start_sigma_m), np.full(3, 2.0),
            np.array([al.sigma_level, al.sigma_level, al.sigma_yaw]),
        )  # fmt: skip
        p15 = ekf.p
        if al.static_samples > 1:
            p15 = level_correlated(p15, self.cbn, normal_gravity(float(nav[0]), float(nav[2])))
        self.c = np.zeros((_N + 2, _N + 2))
        self.c[:_N, :_N] = p15
        self.c[_N, _N], self.c[_N + 1, _N + 1] = opt.start_sigma_m**2, 100.0
        self.x = np.zeros(_N + 2)
        self.x[_N], self.x[_N + 1] = clock_m, drift_mps
        self.t = t

    def predict(self, t: float, opt: TightOptions) -> None:
        if self.t is None or t <= self.t:
            return
        dt = t - self.t
        p = np.ascontiguousarray(self.c[:_N, :_N])
        phi = self._run(t, p)
        extra = t - max(self.t, float(self.imu_t[-1]))
        if extra > 0.0:  # past the last IMU sample: constant velocity, the CV filter's noise
            phi_x = np.eye(_N)
            q_x = np.zeros((_N, _N))
            cv = cv_transition(extra, np.array([opt.q_h, opt.q_h, opt.q_v]))
            phi_x[0:6, 0:6], q_x[0:6, 0:6] = cv
            p = phi_x @ p @ phi_x.T + q_x
            phi = phi_x @ phi
            self._coast(t)
        f, q = clock_transition(dt)
        c = self.c
        out = np.empty_like(c)
        out[:_N, :_N] = p
        out[:_N, _N:] = phi @ c[:_N, _N:] @ f.T
        out[_N:, :_N] = out[:_N, _N:].T
        out[_N:, _N:] = f @ c[_N:, _N:] @ f.T + q
        self.c = 0.5 * (out + out.T)
        self.x[_N:] = f @ self.x[_N:]
        self.t = t

    def _coast(self, t: float) -> None:
        """Past the last IMU sample: move the nav to ``t`` at its velocity."""
        dt = t - self.t_nav
        m, n = radii(self.nav[0])
        h = self.nav[2]
        self.nav[0] += self.nav[4] * dt / (m + h)
        self.nav[1] += self.nav[3] * dt / ((n + h) * np.cos(self.nav[0]))
        self.nav[2] += self.nav[5] * dt
        self.t_nav = t
        self._geometry()

    def _lag(self) -> float:
        """Seconds from the last mechanized IMU sample to the filter time."""
        return 0.0 if self.t is None else max(self.t - self.t_nav, 0.0)

    def _imu_enu(self) -> FloatArray:
        return self.enu + self.rot @ self.nav[3:6] * self._lag()

    def gnss_pos(self) -> FloatArray:
        return self._imu_enu() + self.rot @ (self.cbn @ self.lever_gnss)

    def uwb_pos(self) -> FloatArray:
        return self._imu_enu() + self.rot @ (self.cbn @ self.lever_uwb)

    def vel(self) -> FloatArray:
        return self.rot @ self.nav[3:6]

    def pos_cov(self) -> FloatArray:
        return self.rot @ self.c[:3, :3] @ self.rot.T

    def _rows(self, u_sess: FloatArray, lever: FloatArray | None) -> FloatArray:
        """Rows with the position (lever: and attitude) columns of ``-dh/dr = u``."""
        u = u_sess @ self.rot  # session ENU -> local level (rot^T u)
        h = np.zeros((u.shape[0], _N + 2))
        if lever is None:
            h[:, 3:6] = u
            return h
        h[:, 0:3] = u
        h[:, 6:9] = u @ skew(self.cbn @ lever)
        return h

    def h_code(self, los: FloatArray) -> FloatArray:
        h = self._rows(los, self.lever_gnss)
        h[:, _N] = 1.0
        return h

    def h_rate(self, los: FloatArray) -> FloatArray:
        h = self._rows(los, None)
        h[:, _N + 1] = 1.0
        return h

    def h_range(self, u: FloatArray) -> FloatArray:
        return self._rows(-u[None, :], self.lever_uwb)

    def feedback(self) -> None:
        dx = self.x[:_N]
        if not dx.any():
            return
        self.nav = apply_correction_nb(self.nav, np.ascontiguousarray(dx))
        self.sens += dx[9:15]
        self.x[:_N] = 0.0
        self._geometry()

    def record(self, t: float) -> None:
        x, c = self.x, self.c
        self.x = np.concatenate([self._imu_enu(), self.vel(), x[_N:]])
        self.c = np.zeros((8, 8))
        self.c[:6, :6] = c[:6, :6]
        super().record(t)
        self.x, self.c = x, c
        e = np.degrees(quat_to_euler(self.nav[6:10]))
        att = np.array([e[0], -e[1], np.mod(90.0 - e[2], 360.0)])
        out = self.out
        if len(out.att_deg) == len(out.time_s):
            out.att_deg[-1] = att
        else:
            out.att_deg.append(att)


def track_factory(
    session: Session, frame: LocalFrame, ranges: pd.DataFrame, notes: list[str]
) -> Callable[[str, GnssEpochs, FloatArray], CvTrack]:
    """``make_track`` of :func:`~coopproc.stages.gnss.tight_filter.run_tight`: an
    :class:`InsTrack` for a platform with IMU samples, started and aligned as the INS
    methods do (:func:`coopproc.stages.ins.ins_setup.ins_start` with the ``[ins]``
    defaults: the navigation file, else the first UWB fix), else a :class:`CvTrack`. One
    note per platform in ``notes``."""
    from coopproc.ins.models import imu_figures
    from coopproc.stages.ins.ins_setup import ins_start
    from coopproc.stages.ins.ins_stage import InsParams

    ip = InsParams()

    def make(pid: str, epochs: GnssEpochs, start: FloatArray) -> CvTrack:
        imu = session.imu.get(pid)
        if imu is None or imu.time_s.size < 3:
            return CvTrack(pid, epochs, start)
        nav = session.nav.get(pid)
        by_nav = nav is not None and len(nav) >= 2
        try:
            st = ins_start(
                session, imu, None if by_nav else ranges,
                level_sigma_deg=ip.level_sigma_deg, heading_sigma_deg=ip.heading_sigma_deg,
                tag_up_m=ip.tag_up_m,
            )  # fmt: skip
        except StageError as exc:
            notes.append(f"{pid}: no INS start ({exc}); constant-velocity model")
            return CvTrack(pid, epochs, start)
        al, vel, how = st.alignment, st.vel_enu_mps, st.how
        if by_nav and _moves(nav, imu.time_s[0], imu.time_s[max(al.static_samples - 1, 0)]):
            # steady motion looks static to the IMU: the levelling has the acceleration in
            # it; the in-motion sigmas and the navigation file's velocity instead
            al = replace(al, sigma_level=float(np.radians(ip.level_sigma_deg)),
                         sigma_yaw=max(al.sigma_yaw, float(np.radians(ip.heading_sigma_deg))),
                         static_samples=0)  # fmt: skip
            assert nav is not None
            vel = _nav_velocity(nav, float(imu.time_s[0]))
            how += "; moving in the navigation file: in-motion sigmas"
        cfg = session.platforms[pid]
        levers = (
            np.asarray(cfg.gnss_lever_arm_m or (0.0, 0.0, 0.0), dtype=np.float64),
            np.asarray(cfg.uwb_lever_arm_m or (0.0, 0.0, 0.0), dtype=np.float64),
        )
        notes.append(
            f"{pid}: with the INS (paper 002: 15 INS error states + clock; "
            f"{imu.time_s.size} IMU samples, no NHC/odometer; start: {how})"
        )
        return InsTrack(pid, epochs, start, frame, imu, imu_figures(cfg.imu), al, vel,
                        levers)  # fmt: skip

    return make


def _moves(nav: Trajectory | None, t0: float, t1: float) -> bool:
    """Whether the navigation file moves more than 0.5 m horizontally in [t0, t1]."""
    if nav is None or t1 <= t0:
        return False
    pts = nav.enu_m[(nav.time_s >= t0) & (nav.time_s <= t1), :2]
    return bool(pts.shape[0] >= 2 and np.linalg.norm(pts - pts[0], axis=1).max() > 0.5)


def _nav_velocity(nav: Trajectory, t: float) -> FloatArray:
    """Mean velocity of the navigation file over (t, t + 1 s)."""
    a = np.array([np.interp(t, nav.time_s, nav.enu_m[:, i]) for i in range(3)])
    b = np.array([np.interp(t + 1.0, nav.time_s, nav.enu_m[:, i]) for i in range(3)])
    return b - a
