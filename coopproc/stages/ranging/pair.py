"""One pair's inputs to the ranging stage at its range epochs (paper 000 sec. 3.1).

:func:`prepare_pair` gathers, per pair: the observed ranges, DR DI from each platform's
own navigation and CP DI from the cooperative solution (eq. (1)), the DI variance of
eq. (7) from the platforms' drift figures, the reference distance, the RN increments
from the relative velocity, and the distance filter's numbers (:func:`kernel_params`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, Session, Trajectory, pair_members
from coopproc.stages.ranging.calibration import robust_sigma, window_slices
from coopproc.stages.ranging.config import RangingConfig
from coopproc.stages.ranging.di import anchored_increments, di_variance, range_increments
from coopproc.stages.ranging.nlos import KernelParams
from coopproc.stages.ranging.outliers import gross_outliers
from coopproc.stages.ranging.rn import rn_increments
from coopproc.stages.ranging.table import pair_columns, platform_positions, reference_positions
from coopproc.stages.ranging.tracks import PlatformTracks

__all__ = ["PairInputs", "kernel_params", "prepare_pair"]


def _drift(session: Session, platform: str, config: RangingConfig) -> float:
    info = session.platforms.get(platform)
    if info is None:
        return config.di.drift_follower_mps
    if info.drift_sigma_mps is not None:
        return float(info.drift_sigma_mps)
    if info.role == "anchor":
        return 0.0
    return config.di.drift_leader_mps if info.role == "leader" else config.di.drift_follower_mps


def _initial_sigma(range_m: FloatArray, di_m: FloatArray, config: RangingConfig) -> float:
    """Robust first guess of the UWB sigma: MAD of (range difference - DI) / sqrt(2)."""
    e = np.diff(range_m) - di_m[1:]
    e = e[np.isfinite(e)]
    if e.shape[0] < 5:
        return config.nlos.default_sigma_m
    mad = float(np.median(np.abs(e - np.median(e))))
    return max(1.4826 * mad / np.sqrt(2.0), config.nlos.min_sigma_m)


def rn_variance(
    time_s: FloatArray,
    session: Session,
    config: RangingConfig,
    members: tuple[str, str],
    tracks: PlatformTracks,
) -> FloatArray:
    """Eq. (7) for the RN increments (relative velocity x dt): each end's term is its
    position drift when its velocity is differenced from its positions (the DR DI's
    term), and ``[ranging.rn] velocity_sigma_mps`` when its nav file carries a velocity.
    A GNSS/INS leader's position noise is not in its INS velocity: with the drift term a
    leader declared 0.31 m/s (GNSS noise 0.3 m) put RN in ranges-only windows on every
    pair with it (gain 0.94) although its increments erred by 0.028 m a second, and RN
    found none of 4 events (issue 30.5)."""
    drifts = [
        config.rn.velocity_sigma_mps if tracks.measured_velocity(m) else _drift(session, m, config)
        for m in members
    ]
    return di_variance(time_s, drifts[0], drifts[1], config.di.drift_scaling)


def velocity_windows(
    time_s: FloatArray,
    range_m: FloatArray,
    di_dr_m: FloatArray,
    var_m2: FloatArray,
    rn_m: FloatArray,
    rn_var_m2: FloatArray,
    window_s: float,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """The DR DI of a pair with a measured velocity (an INS or GNSS/INS nav file's
    velocity columns) at one end: per calibration window (local.py's grid), the position
    differences (paper 000's DR DI) or the relative velocity x dt (the RN increments),
    whichever the ranges contradict less (the smaller robust spread of range change -
    increment; the range noise is common to both). A GNSS/INS leader's positions carry
    its GNSS noise, which its INS velocity does not: leader GNSS noise 0.3 m, the
    position DI erred by 0.28 m a second and the velocity one by 0.028 m, and with the
    position DI every window was ranges-only (issue 30.5). Returns the DI, its eq. (7)
    variance and where it is the velocity's."""
    used = np.zeros(time_s.shape[0], dtype=bool)
    if time_s.shape[0] < 3:
        return di_dr_m, var_m2, used
    change = np.empty_like(range_m)
    change[0] = np.nan
    change[1:] = np.diff(range_m)
    di, var = di_dr_m.copy(), var_m2.copy()
    for lo, hi in window_slices(time_s, window_s):
        by_nav = robust_sigma(change[lo:hi] - di_dr_m[lo:hi])
        by_velocity = robust_sigma(change[lo:hi] - rn_m[lo:hi])
        if by_velocity < by_nav:
            di[lo:hi], var[lo:hi] = rn_m[lo:hi], rn_var_m2[lo:hi]
            used[lo:hi] = True
    return di, var, used


def kernel_params(
    config: RangingConfig, sigma_m: float, initial_sigma_m: float, adaptive_n: int, rn: bool
) -> KernelParams:
    """The distance filter's numbers from the config: DI-Based, or RN-Based (``rn``: one-shot
    estimate at detection, no back-dating, no false-alarm check, no suspects)."""
    nlos = config.nlos
    return KernelParams(
        sigma_m=sigma_m,
        initial_sigma_m=initial_sigma_m,
        gamma_sigma=nlos.gamma_sigma,
        window_s=nlos.window_s,
        aligned=config.distance.transition == "aligned",
        di_accel_sigma=config.distance.di_accel_sigma,
        one_shot=rn,
        backdate_s=0.0 if rn else nlos.backdate_s,
        onset_fraction=nlos.onset_fraction,
        confirm_fraction=0.0 if rn else nlos.confirm_fraction,
        end_confirm_s=nlos.end_confirm_s,
        end_min_epochs=nlos.end_min_epochs,
        adaptive_n=adaptive_n,
        adaptive_min_n=nlos.adaptive_min_epochs,
        min_sigma_m=nlos.min_sigma_m,
        suspect_epochs=0 if rn else nlos.suspect_epochs,
        positive_only=nlos.positive_only,
        max_event_s=nlos.max_event_s,
        restart_gap_s=nlos.restart_gap_s,
        jump_fraction=nlos.jump_fraction,
        jump_window_s=nlos.jump_window_s,
    )


@dataclass(frozen=True, eq=False)
class PairInputs:
    """One pair's inputs at its range epochs."""

    name: str
    members: tuple[str, str]
    time_s: FloatArray
    observed_m: FloatArray
    nav_m: tuple[FloatArray, FloatArray]
    cp_m: tuple[FloatArray, FloatArray]
    di_dr_m: FloatArray
    di_cp_m: FloatArray
    di_ref_m: FloatArray
    var_m2: FloatArray
    reference_m: FloatArray
    rn_m: FloatArray
    #: eq. (7) for the RN increments: a measured-velocity end's term is its velocity's
    #: noise, not its position drift (:func:`rn_variance`)
    rn_var_m2: FloatArray
    #: epochs whose DR DI is the relative velocity's, not the positions' (velocity_windows)
    di_by_velocity: NDArray[np.bool_]
    params: KernelParams
    sigma_source: str
    #: gross outliers (outliers.py): not used by the filters, ``outlier = 1`` in ranges.csv
    outlier: NDArray[np.bool_]

    @property
    def kept_m(self) -> FloatArray:
        """The observed ranges the filters use: NaN at the gross outliers."""
        if not self.outlier.any():
            return self.observed_m
        return np.where(self.outlier, np.nan, self.observed_m)


def prepare_pair(
    session: Session,
    cp: Mapping[str, Trajectory],
    config: RangingConfig,
    pair: str,
    tracks: PlatformTracks | None = None,
) -> PairInputs:
    """One pair's inputs. ``tracks``: the platforms' navigation prepared for every pair
    (:class:`PlatformTracks`; None: for this pair alone); the caller calls its ``done``."""
    if tracks is None:
        tracks = PlatformTracks(session, config, [pair])
    t, obs = pair_columns(session, pair)
    a, b = pair_members(pair)
    dr_a = tracks.positions(a, t, corrected=True)
    dr_b = tracks.positions(b, t, corrected=True)
    cp_a = platform_positions(session, cp, a, t, "cooperative solution", True)
    cp_b = platform_positions(session, cp, b, t, "cooperative solution", True)
    ref_a = reference_positions(session, a, t)
    ref_b = reference_positions(session, b, t)
    if config.di.dr_base == "cp":
        di_dr = anchored_increments(cp_a, cp_b, dr_a, dr_b)
    else:
        di_dr = range_increments(dr_a, dr_b)
    var = di_variance(
        t, _drift(session, a, config), _drift(session, b, config), config.di.drift_scaling
    )

    if session.config.uwb_sigma_m is not None:
        sigma, source = float(session.config.uwb_sigma_m), "session.toml"
    elif config.nlos.adaptive:
        sigma, source = -1.0, "adaptive"
    else:
        sigma, source = config.nlos.default_sigma_m, "default"
    dt = np.diff(t)
    step_s = float(np.median(dt[dt > 0])) if np.any(dt > 0) else 1.0
    adaptive_n = max(round(config.nlos.adaptive_window_s / step_s), 1)
    di_cp = range_increments(cp_a, cp_b)
    outlier = gross_outliers(obs, di_dr, config.outliers, di_cp)
    initial = _initial_sigma(np.where(outlier, np.nan, obs), di_dr, config)

    tm = np.empty_like(t)
    tm[:1] = t[:1]
    tm[1:] = 0.5 * (t[1:] + t[:-1])
    rn_inc = rn_increments(
        t,
        tracks.positions(a, tm),
        tracks.positions(b, tm),
        tracks.velocity(a, tm),
        tracks.velocity(b, tm),
    )
    rn_var = rn_variance(t, session, config, (a, b), tracks)
    by_velocity = np.zeros(t.shape[0], dtype=bool)
    if tracks.measured_velocity(a) or tracks.measured_velocity(b):
        di_dr, var, by_velocity = velocity_windows(
            t, np.where(outlier, np.nan, obs), di_dr, var, rn_inc, rn_var,
            config.nlos.calibration_window_s,
        )  # fmt: skip
    return PairInputs(
        name=pair,
        members=(a, b),
        time_s=t,
        observed_m=obs,
        nav_m=(dr_a, dr_b),
        cp_m=(cp_a, cp_b),
        di_dr_m=di_dr,
        di_cp_m=di_cp,
        di_ref_m=range_increments(ref_a, ref_b),
        var_m2=var,
        reference_m=slant_ranges(ref_a - ref_b),
        rn_m=rn_inc,
        rn_var_m2=rn_var,
        di_by_velocity=by_velocity,
        params=kernel_params(config, sigma, initial, adaptive_n, rn=False),
        sigma_source=source,
        outlier=outlier,
    )
