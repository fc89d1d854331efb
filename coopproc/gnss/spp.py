"""Single-point positioning (SPP) from GPS code pseudoranges, epoch by epoch.

Per epoch (docs/methods-gnss.md gives the equations and references):

1. the transmission time t_tx = t_rx - P / c - dt_sv (receiver epoch time, satellite
   clock with relativity and TGD, :mod:`coopproc.gnss.ephemeris`): P / c holds the
   receiver clock offset too, so t_tx is the true GPS time of transmission whatever
   that offset is; the satellite states at t_tx;
2. weighted least squares on x, y, z, c dt_r (Gauss-Newton, start at the previous
   epoch's solution or the earth's centre): the modelled pseudorange
   rho + c dt_r - c dt_sv + I + T, rho the range with the earth's rotation during the
   signal travel (Sagnac); I Klobuchar, T Saastamoinen; satellites below the elevation
   mask dropped once the position is near the earth's surface; weights 1 / sigma^2
   with the elevation-dependent sigma of :func:`~coopproc.gnss.corrections.code_variance_m2`;
3. RAIM (``raim``): the chi-square test of the weighted residuals (false-alarm
   probability ``raim_alpha``); when it fails and at least 6 satellites are left, the
   one with the largest standardised residual (Baarda's w-test) is excluded, the
   solution recomputed and retested; an epoch still failing has no solution;
4. an epoch with fewer than 4 satellites or a GDOP above ``max_gdop`` has no solution.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from coopproc.distributions import chi2_ppf
from coopproc.errors import InputError
from coopproc.gnss.corrections import (
    CodeErrorModel,
    azel,
    code_variance_m2,
    ecef_to_llh,
    klobuchar_s,
    saastamoinen_m,
)
from coopproc.gnss.ephemeris import (
    SPEED_OF_LIGHT,
    GpsEphemerides,
    SatStates,
    geometric_range,
    satellite_states,
)
from coopproc.gnss.rinex_obs import GnssObservations
from coopproc.model import FloatArray

__all__ = ["CODE_L1", "SppOptions", "SppSolution", "solve_spp"]

#: L1 code observations in order of preference (RINEX 3 and RINEX 2 names).
CODE_L1 = ("C1C", "C1", "C1W", "C1P", "P1", "C1X")

ProgressFn = Callable[[int, int], None]


@dataclass(frozen=True)
class SppOptions:
    """Settings of :func:`solve_spp` (defaults as RTKLIB's single mode)."""

    elevation_mask_deg: float = 10.0
    iono: bool = True
    tropo: bool = True
    raim: bool = False
    raim_alpha: float = 0.001
    max_gdop: float = 30.0
    max_iterations: int = 10
    errors: CodeErrorModel = field(default_factory=CodeErrorModel)


@dataclass(frozen=True)
class SppSolution:
    """The epochs with a solution (m of them) and what happened to the others.

    ``time_gpst_s`` the solution time (receiver epoch minus the estimated receiver clock,
    as RTKLIB); ``epoch_gpst_s`` the receiver epoch; ``ecef_m`` (m, 3);
    ``cov_ecef_m2`` (m, 3, 3); ``clock_m`` c dt_r; ``n_sat`` satellites used; ``gdop``;
    ``excluded`` RAIM exclusions as (epoch time, prn); ``no_solution`` reason -> count of
    epochs without a solution; ``epochs`` all epochs of the file.
    """

    time_gpst_s: FloatArray
    epoch_gpst_s: FloatArray
    ecef_m: FloatArray
    cov_ecef_m2: FloatArray
    clock_m: FloatArray
    n_sat: NDArray[np.int64]
    gdop: FloatArray
    excluded: list[tuple[float, int]]
    no_solution: dict[str, int]
    epochs: int


@dataclass
class _Epoch:
    prn: NDArray[np.int64]
    code_m: FloatArray
    states: SatStates


def _check_validity(obs: GnssObservations, eph: GpsEphemerides, valid: NDArray[np.bool_]) -> None:
    """One-line error when an epoch has 4+ GPS pseudoranges but lost satellites below 4
    because no ephemeris covers its time."""
    m = obs.epoch_gpst_s.shape[0]
    have = np.bincount(obs.epoch_index, minlength=m)
    good = np.bincount(obs.epoch_index[valid], minlength=m)
    bad = np.flatnonzero((have >= 4) & (good < 4))
    if bad.size == 0:
        return
    first = int(bad[0])
    if obs.epoch_line is not None:
        line = int(obs.epoch_line[first])
    else:  # the first satellite's line
        line = int(obs.line[np.flatnonzero(obs.epoch_index == first)[0]])
    cover = (
        f"{_text(eph.toe_gpst_s.min() - 7200)} .. {_text(eph.toe_gpst_s.max() + 7200)}"
        if len(eph)
        else "nothing"
    )
    raise InputError(
        obs.source,
        f"epoch {_text(obs.epoch_gpst_s[first])} GPST ({bad.size} of {m} epochs) outside the "
        f"ephemerides' validity (the navigation file(s) cover {cover}); give the navigation "
        "file of that day",
        line=line,
    )


def _text(gpst_s: float) -> str:
    t = np.datetime64("1980-01-06T00:00:00", "s") + np.timedelta64(round(gpst_s), "s")
    return str(t).replace("T", " ")


def solve_spp(
    obs: GnssObservations,
    eph: GpsEphemerides,
    options: SppOptions | None = None,
    progress: ProgressFn | None = None,
) -> SppSolution:
    """SPP of every epoch of ``obs`` (GPS L1 code) with the ephemerides ``eph``."""
    opt = options or SppOptions()
    code = obs.code(CODE_L1)
    use = (obs.system == "G") & np.isfinite(code) & (code > 1.5e7) & (code < 3.5e7)
    if not use.any():
        raise InputError(
            obs.source, f"no GPS L1 code pseudoranges ({'/'.join(CODE_L1)}) in the file"
        )
    rows = np.flatnonzero(use)
    t_rx = obs.epoch_gpst_s[obs.epoch_index[rows]]
    t_tx = t_rx - code[rows] / SPEED_OF_LIGHT
    first = satellite_states(eph, obs.prn[rows], t_tx)
    valid = np.zeros(obs.prn.shape[0], dtype=bool)
    valid[rows] = first.valid
    _check_validity(obs, eph, valid)
    states = satellite_states(eph, obs.prn[rows], t_tx - np.nan_to_num(first.clock_l1_s))
    out = _Collector()
    m = obs.epoch_gpst_s.shape[0]
    starts = np.searchsorted(obs.epoch_index[rows], np.arange(m + 1))
    x = np.zeros(4)
    for k in range(m):
        sel = slice(starts[k], starts[k + 1])
        ok = states.valid[sel]
        epoch = _Epoch(obs.prn[rows][sel][ok], code[rows][sel][ok], _take(states, sel, ok))
        x = _solve_epoch(epoch, float(obs.epoch_gpst_s[k]), eph, opt, x, out)
        if progress is not None:
            progress(k + 1, m)
    return out.solution(m)


def _take(s: SatStates, sel: slice, ok: NDArray[np.bool_]) -> SatStates:
    return SatStates(
        pos_ecef_m=s.pos_ecef_m[sel][ok],
        vel_ecef_mps=s.vel_ecef_mps[sel][ok],
        clock_s=s.clock_s[sel][ok],
        clock_drift_sps=s.clock_drift_sps[sel][ok],
        relativistic_s=s.relativistic_s[sel][ok],
        tgd_s=s.tgd_s[sel][ok],
        valid=s.valid[sel][ok],
        record=s.record[sel][ok],
    )


class _Collector:
    def __init__(self) -> None:
        self.rows: list[tuple[float, float, FloatArray, FloatArray, float, int, float]] = []
        self.excluded: list[tuple[float, int]] = []
        self.no_solution: dict[str, int] = {}

    def fail(self, reason: str) -> None:
        self.no_solution[reason] = self.no_solution.get(reason, 0) + 1

    def solution(self, epochs: int) -> SppSolution:
        r = self.rows
        return SppSolution(
            time_gpst_s=np.array([v[0] for v in r], dtype=np.float64),
            epoch_gpst_s=np.array([v[1] for v in r], dtype=np.float64),
            ecef_m=np.array([v[2] for v in r], dtype=np.float64).reshape(-1, 3),
            cov_ecef_m2=np.array([v[3] for v in r], dtype=np.float64).reshape(-1, 3, 3),
            clock_m=np.array([v[4] for v in r], dtype=np.float64),
            n_sat=np.array([v[5] for v in r], dtype=np.int64),
            gdop=np.array([v[6] for v in r], dtype=np.float64),
            excluded=self.excluded,
            no_solution=self.no_solution,
            epochs=epochs,
        )


def _solve_epoch(
    ep: _Epoch, t_rx: float, eph: GpsEphemerides, opt: SppOptions, x0: FloatArray, out: _Collector
) -> FloatArray:
    """Solve one epoch into ``out``; returns the next epoch's start state."""
    keep = np.ones(ep.prn.shape[0], dtype=bool)
    fit = _wls(ep, keep, t_rx, eph, opt, x0)
    if fit is None:
        out.fail("fewer than 4 satellites")
        return x0
    if opt.raim:
        passed = _chi2_ok(fit, opt)
        if not passed and fit.used.sum() >= 6:
            worst = int(np.argmax(_standardised(fit)))
            keep[worst] = False
            retry = _wls(ep, keep, t_rx, eph, opt, fit.x)
            if retry is not None and _chi2_ok(retry, opt):
                out.excluded.append((t_rx, int(ep.prn[worst])))
                fit, passed = retry, True
        if not passed:
            out.fail("RAIM: chi-square test failed")
            return fit.x
    if fit.gdop > opt.max_gdop:
        out.fail(f"GDOP above {opt.max_gdop:g}")
        return fit.x
    out.rows.append(
        (
            t_rx - fit.x[3] / SPEED_OF_LIGHT,
            t_rx,
            fit.x[:3].copy(),
            fit.cov,
            float(fit.x[3]),
            int(fit.used.sum()),
            fit.gdop,
        )
    )
    return fit.x


@dataclass
class _Fit:
    x: FloatArray
    v: FloatArray
    var: FloatArray
    used: NDArray[np.bool_]
    cov: FloatArray
    gdop: float
    h: FloatArray
    q: FloatArray


def _standardised(fit: _Fit) -> FloatArray:
    """|v| / sigma_v of each used residual (Baarda's w-test; -1 for the unused), with
    the residual covariance Q_v = R - H (H^T W H)^-1 H^T."""
    h = fit.h[fit.used]
    q_v = fit.var[fit.used] - np.einsum("ij,jk,ik->i", h, fit.q, h)
    out = np.full(fit.v.shape[0], -1.0)
    out[fit.used] = np.abs(fit.v[fit.used]) / np.sqrt(np.maximum(q_v, 1e-12))
    return out


def _chi2_ok(fit: _Fit, opt: SppOptions) -> bool:
    dof = int(fit.used.sum()) - 4
    if dof < 1:
        return True
    stat = float(np.sum(fit.v[fit.used] ** 2 / fit.var[fit.used]))
    return stat <= _chi2_limit(opt.raim_alpha, dof)


@lru_cache(maxsize=256)
def _chi2_limit(alpha: float, dof: int) -> float:
    return float(chi2_ppf(1.0 - alpha, dof))


def _wls(
    ep: _Epoch,
    keep: NDArray[np.bool_],
    t_rx: float,
    eph: GpsEphemerides,
    opt: SppOptions,
    x0: FloatArray,
) -> _Fit | None:
    """Gauss-Newton weighted least squares of one epoch with the satellites ``keep``."""
    x = x0.copy()
    mask = np.radians(opt.elevation_mask_deg)
    s = ep.states
    for _ in range(opt.max_iterations):
        sat = s.pos_ecef_m
        rho, unit = geometric_range(sat, x[:3])  # with the earth's rotation in the travel
        near_surface = bool(np.linalg.norm(x[:3]) > 6.0e6)
        iono = np.zeros_like(rho)
        tropo = np.zeros_like(rho)
        if near_surface:
            lat, lon, h = ecef_to_llh(x[:3])
            az, el = azel(x[:3], sat, (lat, lon))
            used = keep & (el >= mask)
            if opt.iono and eph.iono_alpha is not None and eph.iono_beta is not None:
                iono = SPEED_OF_LIGHT * klobuchar_s(
                    t_rx, lat, lon, az, el, eph.iono_alpha, eph.iono_beta
                )
            if opt.tropo:
                tropo = saastamoinen_m(lat, h, el)
        else:
            el = np.full_like(rho, np.pi / 2.0)
            used = keep.copy()
        if used.sum() < 4:
            return None
        model = rho + x[3] - SPEED_OF_LIGHT * (s.clock_s - s.tgd_s) + iono + tropo
        v = ep.code_m - model
        var = code_variance_m2(el, iono, opt.tropo and near_surface, opt.errors)
        h_mat = np.column_stack([-unit, np.ones_like(rho)])
        hu, vu, wu = h_mat[used], v[used], 1.0 / var[used]
        normal = hu.T @ (hu * wu[:, None])
        try:
            q = np.linalg.inv(normal)
        except np.linalg.LinAlgError:
            return None
        dx = q @ (hu.T @ (wu * vu))
        x = x + dx
        if np.linalg.norm(dx) < 1e-4:
            break
    else:
        return None
    try:
        gdop = float(np.sqrt(np.trace(np.linalg.inv(hu.T @ hu))))
    except np.linalg.LinAlgError:
        return None
    # the residuals at the solution (one more model evaluation is not needed at 1e-4 m)
    v = v - h_mat @ dx
    return _Fit(x=x, v=v, var=var, used=used, cov=q[:3, :3], gdop=gdop, h=h_mat, q=q)
