"""Odometer + UWB: a 2D EKF and RTS smoother for platforms with an odometer (``odo_<ID>.csv``).

Methods ``odo_uwb`` (causal filter) and ``odo_uwb_rts`` (filter + Rauch-Tung-Striebel,
paper 003 sec. 2.8). Prediction from the wheel speeds (forward speed and yaw rate, zero-
order hold), tightly coupled range updates to fixed anchors with IGG-III (paper 002 eq.
(18)-(20)); the equations are in :mod:`coopproc.stages.odometry.odo_kernel` and
docs/methods-fusion.md. The yaw rate comes from the odometer (wheel speeds + wheelbase,
or a twist), else from the platform's IMU (z gyro averaged over each odometer interval);
a platform with neither is skipped with a note.

What the data decides (maximum likelihood of the range innovations, the kernel's NLL):

1. the initial heading (24 candidates, 15 deg apart) and the yaw-rate scale (1, or with
   ``search_yaw_scale`` +-{0.5, 0.71, 1, 1.41, 2}: a wrong wheelbase or swapped wheels),
   on the first ``calib_distance_m`` of travel;
2. the wheel-speed noise (speed and yaw-rate 1-sigma per sample) and a factor on the
   declared range sigma, each on a grid unless given (speed, yaw rate, range, speed, yaw
   rate: one at a time, the others held);
3. step 1 again with that noise, around the first choice (+-30 deg, one scale step). The
   filter then runs with these as its start; the scales, the yaw-rate bias and the range
   bias remain states.

The inputs (steps, ranges, initial fix, yaw-rate source) are made by
:mod:`coopproc.stages.odometry.odo_track`. The noise search runs on at most the first
``NOISE_STEPS`` steps, so that an hour of data costs a few filter passes, not 50.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.estimation.kalman import rts_backward_nb
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.base import PositionInput, PositionProduct, PositionStage
from coopproc.stages.odometry.odo_kernel import odo_forward
from coopproc.stages.odometry.odo_track import OdoTrack, OdoUwbParams, head_of, odo_tracks

__all__ = ["ODO_UWB", "ODO_UWB_RTS", "OdoFit", "fit_note", "fit_track", "odo_uwb_positions"]

HEADINGS = np.radians(np.arange(0.0, 360.0, 15.0))
YAW_SCALES = (0.5, 2**-0.5, 1.0, 2**0.5, 2.0)
SPEED_SIGMAS = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
YAW_SIGMAS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)
#: factors on the declared range sigma
RANGE_SCALES = (0.35, 0.5, 0.71, 1.0, 1.41, 2.0, 2.83)
#: the speed and yaw-rate noise and range-sigma factor the first heading search runs with
START_SIGMAS = (0.05, 0.1, 1.0)
MAD_WINDOW = 50
#: the most steps the wheel-speed noise search runs on
NOISE_STEPS = 5000


@dataclass(frozen=True, eq=False)
class OdoFit:
    """The filter's (and smoother's) solution with the choices the data made."""

    xf: FloatArray
    cf: FloatArray
    xs: FloatArray
    cs: FloatArray
    innov: FloatArray  # (R, 3): innovation, its variance, gamma
    heading0_rad: float
    yaw_scale0: float
    speed_sigma_mps: float
    yaw_sigma_radps: float
    range_scale: float
    sigmas_estimated: bool


Fits = tuple[dict[str, OdoTrack], dict[str, OdoFit], list[str]]


def _run(
    track: OdoTrack,
    params: OdoUwbParams,
    heading: float,
    yaw_scale: float,
    sigmas: tuple[float, float, float],
    searched: bool,
) -> tuple[FloatArray, ...]:
    x0 = np.array([track.init_pos[0], track.init_pos[1], heading, 1.0, yaw_scale, 0.0, 0.0])
    yaw_sigma = params.yaw_scale_sigma * (4.0 if searched else 1.0) * abs(yaw_scale)
    c0 = np.diag(
        [
            track.init_sigma_m**2,
            track.init_sigma_m**2,
            np.radians(10.0) ** 2,
            params.speed_scale_sigma**2,
            yaw_sigma**2,
            params.yaw_bias_sigma_radps**2,
            params.range_bias_sigma_m**2,
        ]
    )
    q = np.array(
        [
            sigmas[0] ** 2 * track.interval_s,
            sigmas[1] ** 2 * track.interval_s,
            params.position_psd,
            params.scale_psd,
            params.scale_psd,
            params.bias_psd,
            0.0,
        ]
    )
    return odo_forward(  # type: ignore[no-any-return]
        track.t,
        track.v,
        track.w,
        track.ptr,
        track.anchor,
        track.rng,
        track.var * sigmas[2] ** 2,
        track.up,
        x0,
        c0,
        q,
        params.robust,
        params.k0,
        params.k1,
        MAD_WINDOW,
    )


def _nll(
    track: OdoTrack,
    params: OdoUwbParams,
    heading: float,
    scale: float,
    sigmas: tuple[float, float, float],
) -> float:
    return float(_run(track, params, heading, scale, sigmas, params.search_yaw_scale)[-1][0])


def _search_start(
    track: OdoTrack,
    params: OdoUwbParams,
    sigmas: tuple[float, float, float],
    near: tuple[float, float] | None = None,
) -> tuple[float, float]:
    """Initial heading and yaw-rate scale of least NLL on the calibration stretch: every
    candidate, or (``near``) the neighbours of an earlier choice (+-30 deg, one scale step)."""
    n = int(np.searchsorted(track.distance, params.calib_distance_m, side="right"))
    head = head_of(track, max(min(n, len(track.t)), 1))
    scales = [1.0]
    if params.search_yaw_scale:
        scales = [s * m for s in (1.0, -1.0) for m in YAW_SCALES]
    headings = [float(h) for h in HEADINGS]
    if near is not None:
        step = float(HEADINGS[1] - HEADINGS[0])
        headings = [near[0] + k * step for k in (-2, -1, 0, 1, 2)]
        scales = [s for s in scales if s * near[1] > 0 and 0.7 <= s / near[1] <= 1.42]
    best = (np.inf, 0.0, 1.0)
    for scale in scales:
        for psi in headings:
            nll = _nll(head, params, psi, scale, sigmas)
            if nll < best[0]:
                best = (nll, psi, scale)
    return best[1], best[2]


def _search_sigmas(
    track: OdoTrack,
    params: OdoUwbParams,
    heading: float,
    scale: float,
    start: tuple[float, float, float],
) -> tuple[float, float, float]:
    """Wheel-speed noise and range-sigma factor of least NLL, one at a time on its grid
    with the others held (speed, yaw rate, range, speed, yaw rate; given ones kept)."""
    grids = (
        (params.speed_sigma_mps,) if params.speed_sigma_mps > 0 else SPEED_SIGMAS,
        (params.yaw_rate_sigma_radps,) if params.yaw_rate_sigma_radps > 0 else YAW_SIGMAS,
        (params.range_sigma_scale,) if params.range_sigma_scale > 0 else RANGE_SCALES,
    )
    track = head_of(track, min(len(track.t), NOISE_STEPS))
    current = list(start)
    for axis in (0, 1, 2, 0, 1):
        grid = grids[axis]
        scores = []
        for g in grid:
            trial = list(current)
            trial[axis] = g
            sigmas = (trial[0], trial[1], trial[2])
            scores.append(np.inf if len(grid) == 1 else _nll(track, params, heading, scale, sigmas))
        current[axis] = grid[int(np.argmin(scores))]
    return current[0], current[1], current[2]


def fit_track(track: OdoTrack, params: OdoUwbParams) -> OdoFit:
    """Choose the start and the noise by maximum likelihood, filter and smooth."""
    given = (
        params.speed_sigma_mps or START_SIGMAS[0],
        params.yaw_rate_sigma_radps or START_SIGMAS[1],
        params.range_sigma_scale or START_SIGMAS[2],
    )
    heading, scale = _search_start(track, params, given)
    sigmas = _search_sigmas(track, params, heading, scale, given)
    heading, scale = _search_start(track, params, sigmas, near=(heading, scale))
    xf, cf, xp, cp, fs, innov, _ = _run(
        track, params, heading, scale, sigmas, params.search_yaw_scale
    )
    xs, cs = rts_backward_nb(xf, cf, xp, cp, fs)  # paper 003 sec. 2.8
    estimated = 0 in (params.speed_sigma_mps, params.yaw_rate_sigma_radps, params.range_sigma_scale)
    return OdoFit(xf, cf, xs, cs, innov, heading, scale, sigmas[0], sigmas[1], sigmas[2], estimated)


def _trajectory(track: OdoTrack, x: FloatArray, c: FloatArray, source: str) -> Trajectory:
    k_n = x.shape[0]
    enu = np.column_stack([x[:, 0], x[:, 1], track.up])
    sig = np.full((k_n, 3), np.nan)
    sig[:, 0] = np.sqrt(np.maximum(c[:, 0, 0], 0.0))
    sig[:, 1] = np.sqrt(np.maximum(c[:, 1, 1], 0.0))
    speed = x[:, 3] * track.v
    vel = np.column_stack([speed * np.cos(x[:, 2]), speed * np.sin(x[:, 2]), np.zeros(k_n)])
    return Trajectory(track.platform, track.t, enu, sigma_enu_m=sig, vel_enu_mps=vel, source=source)


def fit_note(track: OdoTrack, fit: OdoFit, method: str) -> str:
    """What the data said: NIS, scales, noise, the choices (run summary, run.json)."""
    x, c = fit.xs[-1], fit.cs[-1]
    ok = np.isfinite(fit.innov[:, 0])
    nis = fit.innov[ok, 0] ** 2 / fit.innov[ok, 1]
    gamma = fit.innov[ok, 2]
    kept = gamma == 1.0
    how = "maximum likelihood" if fit.sigmas_estimated else "given"
    text = (
        f"{method} {track.platform}: yaw rate from the {track.yaw_source}; speed scale "
        f"{x[3]:.3f} +- {np.sqrt(c[3, 3]):.3f}, yaw-rate scale {x[4]:.3f} +- "
        f"{np.sqrt(c[4, 4]):.3f}, yaw-rate bias {x[5]:.4f} rad/s, range bias {x[6]:.3f} +- "
        f"{np.sqrt(c[6, 6]):.3f} m; "
    )
    if track.wheelbase_m is not None and abs(x[4]) > 1e-6:
        text += f"effective wheelbase {track.wheelbase_m / x[4]:.4f} m [{track.wheelbase_m} m]; "
    if x[4] < 0:
        text += "the wheel speeds turn opposite to the UWB track (wheels swapped?); "
    text += (
        f"initial heading {np.degrees(fit.heading0_rad):.0f} deg (from the ranges); "
        f"wheel-speed noise ({how}) {fit.speed_sigma_mps:g} m/s, yaw rate "
        f"{fit.yaw_sigma_radps:g} rad/s per sample, range sigma x {fit.range_scale:g} of the "
        f"declared; range NIS mean {np.mean(nis):.2f} "
        f"(kept ranges {np.mean(nis[kept]) if kept.any() else np.nan:.2f}, expected 1), "
        f"{np.count_nonzero(~kept)} of {nis.shape[0]} ranges down-weighted by IGG-III"
    )
    return text


#: the last (session, ranges, params) and its tracks, fits and notes: odo_uwb and
#: odo_uwb_rts run one after the other on the same inputs and share one fit
_LAST: list[tuple[Session, pd.DataFrame, OdoUwbParams, Fits]] = []


def _fits(session: Session, ranges: pd.DataFrame, params: OdoUwbParams) -> Fits:
    """The tracks and fits of every platform (module docstring), computed once per inputs."""
    for s_, r_, p_, done in _LAST:
        if s_ is session and r_ is ranges and p_ == params:
            return done
    tracks, notes = odo_tracks(session, ranges, params)
    done = (tracks, {pid: fit_track(t, params) for pid, t in tracks.items()}, notes)
    _LAST[:] = [(session, ranges, params, done)]
    return done


def odo_uwb_positions(
    session: Session, ranges: pd.DataFrame, params: OdoUwbParams, *, smooth: bool
) -> tuple[dict[str, Trajectory], list[str]]:
    """Every platform with an odometer and anchor ranges: its filtered (``smooth=False``)
    or smoothed trajectory at the step times, and the notes (fit facts, skipped ones)."""
    tracks, fits, skipped = _fits(session, ranges, params)
    notes = list(skipped)
    out: dict[str, Trajectory] = {}
    method = "odo_uwb_rts" if smooth else "odo_uwb"
    for pid, track in tracks.items():
        fit = fits[pid]
        if smooth:
            out[pid] = _trajectory(track, fit.xs, fit.cs, "odometer + UWB EKF + RTS")
        else:
            out[pid] = _trajectory(track, fit.xf, fit.cf, "odometer + UWB EKF")
        notes.append(fit_note(track, fit, method))
    return out, notes


def _stage(inp: PositionInput, params: OdoUwbParams, smooth: bool) -> PositionProduct:
    positions, notes = odo_uwb_positions(inp.session, inp.ranges, params, smooth=smooth)
    return PositionProduct(positions=positions, notes=tuple(notes))


def odo_uwb_stage(inp: PositionInput, params: OdoUwbParams) -> PositionProduct:
    """The causal odometer/UWB filter of every platform with an odometer."""
    return _stage(inp, params, smooth=False)


def odo_uwb_rts_stage(inp: PositionInput, params: OdoUwbParams) -> PositionProduct:
    """The odometer/UWB filter and its RTS smoother."""
    return _stage(inp, params, smooth=True)


def _check(session: Session) -> None:
    if not session.odometer:
        raise StageError(
            "odo_uwb: the session has no odometer (odo_<ID>.csv); the odometer/UWB filter "
            "predicts with wheel speeds"
        )
    if not any(p.role == "anchor" for p in session.platforms.values()):
        raise StageError(
            "odo_uwb: the session has no anchors (platforms with role 'anchor'); the "
            "odometer/UWB filter updates with ranges to fixed anchors"
        )


ODO_UWB = PositionStage(
    name="odo_uwb",
    params_type=OdoUwbParams,
    section="odo_uwb",
    run=odo_uwb_stage,
    help="odometer + UWB: 2D EKF (wheel speeds, ranges to anchors, IGG-III) of every "
    "platform with an odometer (causal), on the observed ranges; method odo_uwb",
    check=_check,
    uwb_only=True,
    requires=frozenset({"odometer", "anchors"}),
    observed_only=True,
)

ODO_UWB_RTS = PositionStage(
    name="odo_uwb_rts",
    params_type=OdoUwbParams,
    section="odo_uwb",
    run=odo_uwb_rts_stage,
    help="the odo_uwb filter followed by the RTS smoother (paper 003 sec. 2.8); method odo_uwb_rts",
    check=_check,
    uwb_only=True,
    requires=frozenset({"odometer", "anchors"}),
    observed_only=True,
)
