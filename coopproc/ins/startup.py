"""The start of an INS whose heading nothing gives: a coarse heading search (issue 31 part 3;
docs/methods-ins.md, "Start").

The error-state filter linearizes the attitude error (psi angles, coopproc.ins.errorstate):
a start heading some tens of degrees off is outside what it can pull in, and the ranges
that should correct it are rejected by IGG-III as the solution runs away (the handcart
made a tag on ranges thinned to 2.2 Hz: the first motion of its sparse fixes said 81 deg,
the truth was 134 deg, and the INS drifted 16-184 m; a quadrotor's heading is not its
course at all). The range-by-range track a tag starts from is poor at its first sample too, and
levelling in motion is off by the acceleration over g. A platform without a navigation
heading and without gyrocompassing is therefore started (:func:`search_heading`) from
each of ``count`` headings spaced 360 / count apart (the first the heading of the first
motion), each with 1-sigma half the spacing, from a wide start (``WIDE_*``; the source's
start velocity and zero both tried), and the forward filter + RTS runs over the first
``window_s`` on the same ranges without IGG-III (a converging filter's large innovations
are not outliers). Score: the RMS of the range innovations normalized by their predicted
sigma, sqrt(H P H^T + R) (the consistency figure of :class:`~coopproc.ins.engine.
InnovationStats`: about 1 when consistent, tens for a run that drifts off). The best
:data:`REFINED` are refined: :data:`REFINE_PASSES` runs over the window, each from the
previous run's smoothed state at the first sample with :data:`INFLATE` times its
smoothed 1-sigmas (an iterated linearization, as Gauss-Newton); the best refined one is
the start. :func:`start_up` repeats it on other windows (:data:`WINDOW_FACTORS`) until a
start fits (:data:`START_NIS_MAX`). The constants were chosen on the quadrotor scenario
(seeds 0-9) and checked on the handcart made a tag (docs/methods-ins.md, "Start").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from coopproc.errors import StageError
from coopproc.ins.aiding import InsAiding
from coopproc.ins.align import Alignment
from coopproc.ins.engine import InsConfig, InsResult, run_ins
from coopproc.model import FloatArray
from coopproc.sensors import ImuData

__all__ = ["START_NIS_MAX", "WINDOW_FACTORS", "HeadingSearch", "search_heading", "start_up"]


#: The wide start of the search runs: 1-sigma position (m) and velocity (m/s) per axis
#: (the range-by-range track a tag starts from was 1.5 m and 1.7 m/s off at the first
#: sample of the quadrotor seed 1 ifo002, with 0.2 m claimed).
WIDE_POS_M, WIDE_VEL_MPS = 3.0, 2.0
#: ... and level (rad): levelled in motion from the first second's specific force, a
#: multirotor's tilt is its acceleration over g plus the accelerometer bias over g (the
#: consumer grade's 30 mg turn-on: 1.7 deg): 4-7 deg on the quadrotor seeds 1-2.
WIDE_LEVEL_RAD = float(np.radians(8.0))
#: Runs over the window from the smoothed first state of the previous one (an iterated
#: linearization, as Gauss-Newton).
REFINE_PASSES = 3
#: The best candidates of the search that are refined; the best refined one is the start.
REFINED = 3
#: Floors of the start's 1-sigmas taken from a smoothed run: position (m), velocity (m/s),
#: level and heading (rad).
FLOOR_POS_M, FLOOR_VEL_MPS = 0.1, 0.05
FLOOR_LEVEL_RAD, FLOOR_YAW_RAD = float(np.radians(0.5)), float(np.radians(2.0))
#: The factor on the smoothed 1-sigmas a start takes from a run: the smoother's
#: covariance of a run linearized about a wrong start is optimistic (the quadrotor seeds
#: 1 and 6 ifo002 fitted on the window from their smoothed start, then ran away on the
#: whole flight with 1x; with 2x every seed 0-9 converged).
INFLATE = 2.0


#: A searched start whose best refined run has a range NIS RMS above this does not fit
#: its ranges (a consistent filter has about 1; the converged quadrotor and handcart
#: starts 0.5-1.4, the ones that ran away 3-20).
START_NIS_MAX = 2.0
#: The windows tried, as factors of the configured one, until a start fits.
WINDOW_FACTORS = (1.0, 2.0, 0.5)


@dataclass(frozen=True, eq=False)
class HeadingSearch:
    """The start found (``config``: alignment, position, velocity and their 1-sigmas),
    every candidate's (yaw rad, range NIS RMS) and the last refining run's NIS RMS."""

    config: InsConfig
    scores: tuple[tuple[float, float], ...]
    refined_nis: float
    #: seconds of IMU the candidates ran on
    window_s: float = 0.0

    @property
    def alignment(self) -> Alignment:
        assert self.config.alignment is not None
        return self.config.alignment

    def describe(self) -> str:
        """For the run's note: the chosen heading and how clearly it won."""
        best = min(s for _, s in self.scores)
        rest = sorted(s for _, s in self.scores)[1] if len(self.scores) > 1 else best
        yaw = np.degrees(self.alignment.yaw) % 360.0
        return (
            f"coarse search over {len(self.scores)} headings on the first "
            f"{self.window_s:.0f} s: {yaw:.0f} deg ENU "
            f"(range NIS RMS {best:.2f}, next best {rest:.2f}, first motion's "
            f"{self.scores[0][1]:.2f}; refined {self.refined_nis:.2f})"
        )


def _window(imu: ImuData, end_s: float) -> ImuData:
    keep = imu.time_s <= end_s
    return dataclasses.replace(
        imu, time_s=imu.time_s[keep], gyro_radps=imu.gyro_radps[keep],
        accel_mps2=imu.accel_mps2[keep],
    )  # fmt: skip


def _start_of(
    res: InsResult, al: Alignment
) -> tuple[FloatArray, FloatArray, Alignment, float, float]:
    """(position, velocity, alignment, sigma pos, sigma vel) at the first sample of a
    smoothed run: its state and 1-sigmas (the largest axis, at least the floors)."""
    sm = res.smoothed
    assert sm is not None
    roll, pitch, yaw = np.radians(sm.att_deg[0])
    sig_att = np.radians(sm.sigma_att_deg[0])
    al = dataclasses.replace(
        al, roll=float(roll), pitch=float(pitch), yaw=float(yaw), heading_source="search",
        sigma_level=max(INFLATE * float(np.max(sig_att[:2])), FLOOR_LEVEL_RAD),
        sigma_yaw=max(INFLATE * float(sig_att[2]), FLOOR_YAW_RAD),
    )  # fmt: skip
    sig_p = max(INFLATE * float(np.max(sm.sigma_enu[0])), FLOOR_POS_M)
    sig_v = max(INFLATE * float(np.max(sm.sigma_vel[0])), FLOOR_VEL_MPS)
    return sm.enu_m[0].copy(), sm.vel_enu[0].copy(), al, sig_p, sig_v


def _nis(res: InsResult) -> float:
    nis = next((s.nis_rms for s in res.stats if s.kind == "range"), float("inf"))
    return nis if np.isfinite(nis) else float("inf")


def search_heading(
    imu: ImuData,
    aiding: InsAiding,
    config: InsConfig,
    *,
    window_s: float,
    count: int,
) -> HeadingSearch:
    """The start of an INS without a given heading (module docstring): the best of
    ``count`` headings around ``config.alignment.yaw``, each run over the first
    ``window_s`` of ``imu`` from the wide start, then :data:`REFINE_PASSES` runs from the
    smoothed first state."""
    al = config.alignment
    if al is None or aiding.ranges is None:
        raise StageError(f"INS of {imu.platform}: a heading search needs an alignment and ranges")
    short = _window(imu, float(imu.time_s[0]) + window_s)
    plain = dataclasses.replace(aiding, robust=None)
    spacing = 2.0 * np.pi / count
    wide = dataclasses.replace(
        config, smooth=True, sigma_pos_m=max(config.sigma_pos_m, WIDE_POS_M),
        sigma_vel_mps=max(config.sigma_vel_mps, WIDE_VEL_MPS),
    )  # fmt: skip
    scores: list[tuple[float, float]] = []
    runs: list[InsResult] = []
    given = np.asarray(config.start_vel_enu, dtype=np.float64)
    velocities = [given] + ([np.zeros(3)] if np.any(given != 0.0) else [])
    for i in range(count):
        yaw = float(np.angle(np.exp(1j * (al.yaw + i * spacing))))
        cand = dataclasses.replace(
            al, yaw=yaw, sigma_yaw=max(al.sigma_yaw, spacing / 2.0),
            sigma_level=max(al.sigma_level, WIDE_LEVEL_RAD),
        )  # fmt: skip
        tried = [
            run_ins(short, plain, dataclasses.replace(wide, alignment=cand, start_vel_enu=v))
            for v in velocities
        ]
        res = min(tried, key=_nis)
        scores.append((yaw, _nis(res)))
        runs.append(res)
    best: tuple[float, InsConfig] | None = None
    for i in np.argsort([sc for _, sc in scores], kind="stable")[:REFINED]:
        res, chosen = runs[int(i)], al
        for _ in range(REFINE_PASSES):
            pos, vel, chosen, sig_p, sig_v = _start_of(res, chosen)
            step = dataclasses.replace(
                wide, alignment=chosen, start_enu=pos, start_vel_enu=vel, sigma_pos_m=sig_p,
                sigma_vel_mps=sig_v,
            )  # fmt: skip
            res = run_ins(short, plain, step)
        pos, vel, chosen, sig_p, sig_v = _start_of(res, chosen)
        if best is None or _nis(res) < best[0]:
            start = dataclasses.replace(
                config, alignment=chosen, start_enu=pos, start_vel_enu=vel, sigma_pos_m=sig_p,
                sigma_vel_mps=sig_v,
            )  # fmt: skip
            best = (_nis(res), start)
    assert best is not None
    return HeadingSearch(best[1], tuple(scores), best[0], window_s)


def start_up(
    imu: ImuData,
    aiding: InsAiding,
    config: InsConfig,
    *,
    static_s: float,
    window_s: float,
    count: int,
) -> HeadingSearch:
    """:func:`search_heading` over ``static_s`` + each of the windows ``window_s`` x
    :data:`WINDOW_FACTORS` in turn until one fits (:data:`START_NIS_MAX`), else the best
    fit of them (the caller warns). A window that is too short has not moved enough to
    show the heading; one that is too long lets the first seconds' errors grow past
    what the linearized filter pulls in (the quadrotor seed 6 ifo002 fitted on 20 and
    45 s, not on 30 s)."""
    best: HeadingSearch | None = None
    for factor in WINDOW_FACTORS:
        found = search_heading(
            imu, aiding, config, window_s=static_s + factor * window_s, count=count
        )
        if best is None or found.refined_nis < best.refined_nis:
            best = found
        if found.refined_nis <= START_NIS_MAX:
            break
    assert best is not None
    return best
