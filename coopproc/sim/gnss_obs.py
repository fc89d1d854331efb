"""Raw GPS L1 observations of every simulated platform (issue 13 item 6), off by default.

With ``gnss_obs`` the satellites fly the broadcast ephemerides of a real RINEX navigation
file (``gnss_nav``; default the shared GEONET file of 2005-04-02) and each platform's
receiver, at its true position placed at the session's geodetic origin, observes every
satellite above the elevation mask at ``gnss_rate_hz`` (epochs on the receiver's clock,
i.e. on the session's time grid). Per epoch k and satellite s:

    P   = rho + c (dt_r - dt_s) + T + I + M + e_P                        (pseudorange, m)
    L   = (rho + c (dt_r - dt_s) + T - I) / lambda + N + e_L             (carrier, cycles)
    D   = -(rho' + c (dt_r' - dt_s')) / lambda + e_D                     (Doppler, Hz)

- rho: geometric range from the receiver at the true reception time
  (t_tag - dt_r) to the satellite at the transmission time, with the earth's rotation
  during the signal's travel (Sagnac; :func:`coopproc.gnss.ephemeris.rotate_to_reception`),
  iterated to convergence; rho' its rate (central difference over +-0.05 s with the
  receiver's true velocity; one-sided where the step would reach another ephemeris
  record, whose orbit jumps by centimetres to decimetres);
- dt_s: the satellite clock of the broadcast ephemeris for an L1 C/A user (polynomial,
  relativistic term, minus TGD; :class:`~coopproc.gnss.ephemeris.SatStates`);
- dt_r, dt_r': the receiver clock, a TCXO: bias and drift random walks (h0 = 2e-19,
  h-2 = 2e-20, Brown & Hwang 2012 Table 9.1), bias drawn in +-0.5 ms, drift N(0, 1e-7);
- T = Saastamoinen(el) (1 + e_T), e_T ~ N(0, ``gnss_tropo_error``) once per session
  (the platforms are close: one atmosphere); I = Klobuchar(el, az, t) (1 + e_I[s]),
  e_I ~ N(0, ``gnss_iono_error``) per satellite: what an SPP with those two models leaves
  is T e_T + I e_I (:mod:`coopproc.gnss.corrections`);
- M: code multipath, a first-order Gauss-Markov sequence per satellite (correlation time
  ``gnss_multipath_tau_s``) of 1-sigma ``gnss_multipath_m`` / sin(el);
- C/N0 = 32 + 16 sin(el) + N(0, 1) dB-Hz; the white noises e_P, e_D (and e_L, 0.01 cycle)
  have their 45 dB-Hz sigma times 10^((45 - C/N0) / 20);
- N: an integer ambiguity per arc (a new one, and LLI = 1, when a satellite comes back).

``canyon`` segments leave a platform only a few satellites (the highest at the segment's
first epoch, while they stay above the mask). Written by :mod:`coopproc.sim.writer`
through :mod:`coopproc.gnss.rinex_write`; the truth (receiver clock, each error term per
observation) in ``truth/gnss_clock.csv`` and ``truth/gnss_errors.csv``.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Set
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.errors import ConfigError, InputError
from coopproc.frames import enu2ecef, enu2geodetic
from coopproc.gnss.corrections import azel, klobuchar_s, saastamoinen_m
from coopproc.gnss.ephemeris import (
    SPEED_OF_LIGHT,
    GpsEphemerides,
    SatStates,
    rotate_to_reception,
    satellite_states,
)
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_write import L1_WAVELENGTH_M, ObsTable
from coopproc.model import FloatArray, Trajectory
from coopproc.sim.gnss import gauss_markov
from coopproc.sim.params import CanyonSpec, SimParams
from coopproc.sim.scenario_types import named_rng
from coopproc.sim.truth import SimulatedGnss, Simulation

__all__ = [
    "GEONET_ORIGIN_LLH",
    "add_gnss_obs",
    "default_nav_path",
    "gnss_session_params",
    "load_ephemerides",
]

#: Default ENU origin with ``gnss_obs`` and the shared navigation file: between the GEONET
#: stations 0759 and 3040 (Miura peninsula, Japan) whose files it comes with.
GEONET_ORIGIN_LLH = (35.1465, 139.6190, 70.0)
_H0, _H_2 = 2e-19, 2e-20  # TCXO Allan-variance coefficients
_PHASE_SIGMA_CYCLES = 0.01
_DOPPLER_STEP_S = 0.05


def default_nav_path() -> Path:
    """The shared GEONET navigation file beside the repository (``../shared/data/gnss``)."""
    return Path(__file__).resolve().parents[3] / "shared" / "data" / "gnss" / "07590920.05n"


def load_ephemerides(params: SimParams) -> GpsEphemerides:
    """The ephemerides of ``gnss_nav`` (or the default file); ConfigError when missing."""
    path = Path(params.gnss_nav) if params.gnss_nav else default_nav_path()
    if not path.is_file():
        what = "gnss_nav" if params.gnss_nav else "the default navigation file"
        raise ConfigError(f"{what} {path}: no such file (give one with --gnss-nav FILE)")
    stat = path.stat()
    return _read(str(path.resolve()), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=4)
def _read(path: str, mtime_ns: int, size: int) -> GpsEphemerides:
    """A navigation file read once per content (the engine asks twice)."""
    eph = read_nav(path)
    if not len(eph):
        raise InputError(path, "no GPS ephemeris in this navigation file")
    return eph


def _check_canyon(p: SimParams, platforms: Set[str]) -> None:
    dt = 1.0 / p.gnss_rate_hz
    for seg in p.canyon:
        if seg.platform and seg.platform not in platforms:
            raise ConfigError(
                f"canyon segment at {seg.start_s:g} s: no platform '{seg.platform}' "
                f"(platforms: {', '.join(sorted(platforms))})"
            )
        first = np.ceil(seg.start_s / dt - 1e-9) * dt
        if first > seg.end_s + 1e-9 or first > p.duration_s + 1e-9:
            raise ConfigError(
                f"canyon segment {seg.start_s:g}-{seg.end_s:g} s holds no GNSS epoch "
                f"(every {dt:g} s from 0 to {p.duration_s:g} s)"
            )


def gnss_session_params(params: SimParams, given: Set[str]) -> SimParams:
    """``params`` placed in the ephemerides' time (and, with the shared file, near its
    stations) where the caller did not give the time or origin; ConfigError when the
    session lies outside the ephemerides (+-2 h around their first and last toe)."""
    if not params.gnss_obs:
        return params
    eph = load_ephemerides(params)
    low, high = float(eph.toe_gpst_s.min()) - 7200.0, float(eph.toe_gpst_s.max()) + 7200.0
    changes: dict[str, object] = {}
    if not {"gps_week", "start_tow_s"} & given:
        middle = 0.5 * (low + high) - 0.5 * params.duration_s
        start = max(low, float(np.floor(middle / 60.0) * 60.0))
        week, tow = divmod(start, 604800.0)
        if tow + params.duration_s >= 604800.0:  # keep the session inside one week
            week, tow = week + 1, 0.0
        changes |= {"gps_week": int(week), "start_tow_s": tow}
    if "origin_llh" not in given and not params.gnss_nav:
        changes["origin_llh"] = GEONET_ORIGIN_LLH
    out = dataclasses.replace(params, **changes)  # type: ignore[arg-type]
    t0 = out.gps_week * 604800.0 + out.start_tow_s
    if t0 < low or t0 + out.duration_s > high:
        source = params.gnss_nav or str(default_nav_path())
        raise ConfigError(
            f"gnss_obs: the session (GPS week {out.gps_week}, TOW {out.start_tow_s:g} + "
            f"{out.duration_s:g} s) is outside the ephemerides of {source} (GPST "
            f"{low:.0f}-{high:.0f} s, week {int(low // 604800)}); leave gps_week and "
            "start_tow_s unset to take their time"
        )
    return out


def _receiver_clock(n: int, dt: float, rng: np.random.Generator) -> tuple[FloatArray, FloatArray]:
    """Bias (s) and drift (s/s) of a TCXO at ``n`` epochs ``dt`` apart (two random walks)."""
    drift = rng.normal(0.0, 1e-7) + np.concatenate(
        ([0.0], np.cumsum(rng.normal(0.0, np.sqrt(2 * np.pi**2 * _H_2 * dt), n - 1)))
    )
    steps = drift[:-1] * dt + rng.normal(0.0, np.sqrt(_H0 / 2 * dt), n - 1)
    bias = rng.uniform(-5e-4, 5e-4) + np.concatenate(([0.0], np.cumsum(steps)))
    return bias, drift


def _geometry(
    eph: GpsEphemerides,
    prn: np.ndarray,
    t_rx: FloatArray,
    r_ecef: FloatArray,
    tau0: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, SatStates, FloatArray]:
    """Range with Sagnac (m), satellite positions in the frame at reception, states and
    travel times: three iterations from 75 ms (below 1e-10 s), two from ``tau0``."""
    tau = np.full(prn.shape[0], 0.075) if tau0 is None else tau0
    for _ in range(3 if tau0 is None else 2):
        states = satellite_states(eph, prn, t_rx - tau)
        sat = rotate_to_reception(states.pos_ecef_m, tau)
        rho = np.linalg.norm(sat - r_ecef, axis=1)
        tau = np.where(np.isfinite(rho), rho / SPEED_OF_LIGHT, 0.075)
    return rho, sat, states, tau


def _canyon_mask(
    visible: np.ndarray, el: FloatArray, t_rel: FloatArray, segs: list[CanyonSpec]
) -> np.ndarray:
    """``visible`` with each segment's epochs limited to its chosen satellites."""
    out = visible.copy()
    for seg in segs:
        rows = np.flatnonzero((t_rel >= seg.start_s - 1e-9) & (t_rel <= seg.end_s + 1e-9))
        if not rows.size:
            continue
        first = rows[0]
        order = np.argsort(np.where(visible[first], -el[first], np.inf), kind="stable")
        keep = order[: min(seg.satellites, int(visible[first].sum()))]
        allowed = np.zeros(visible.shape[1], dtype=bool)
        allowed[keep] = True
        out[rows] &= allowed
    return out


def _arcs(visible: np.ndarray, rng: np.random.Generator) -> tuple[FloatArray, np.ndarray]:
    """Integer ambiguity (cycles) per arc and the LLI flag (1 where an arc restarts)."""
    start = visible & ~np.vstack([np.zeros((1, visible.shape[1]), dtype=bool), visible[:-1]])
    arc_id = np.cumsum(start, axis=0) + 1000 * np.arange(visible.shape[1])
    ids, inverse = np.unique(arc_id, return_inverse=True)
    values = np.round(rng.uniform(-2e6, 2e6, ids.size))
    lli = (start & (np.arange(visible.shape[0])[:, None] > 0)).astype(np.int64)
    return values[inverse.reshape(visible.shape)], lli


def _platform_obs(
    pid: str,
    truth: Trajectory,
    eph: GpsEphemerides,
    prns: np.ndarray,
    p: SimParams,
    seed: int,
    common: tuple[float, FloatArray],
) -> tuple[ObsTable, pd.DataFrame, pd.DataFrame]:
    dt = 1.0 / p.gnss_rate_hz
    t_rel = np.round(dt * np.arange(int(np.floor(p.duration_s / dt + 1e-9)) + 1), 9)
    week_s = p.gps_week * 604800.0
    t_tag = week_s + p.start_tow_s + t_rel
    n, m = t_rel.size, prns.size
    bias, drift = _receiver_clock(n, dt, named_rng(seed, f"gnss-clock:{pid}"))
    tow_true = np.clip(p.start_tow_s + t_rel - bias, truth.time_s[0], truth.time_s[-1])
    enu = truth.interpolate(tow_true)
    vel_enu = np.column_stack(
        [np.interp(tow_true, truth.time_s, np.gradient(truth.enu_m[:, a], truth.time_s))
         for a in range(3)]
    ) if len(truth) > 1 else np.zeros((n, 3))  # fmt: skip
    r = enu2ecef(enu, p.origin_llh)
    step = enu2ecef(enu + vel_enu * _DOPPLER_STEP_S, p.origin_llh) - r
    llh = enu2geodetic(enu, p.origin_llh)
    # every (epoch, satellite) at once
    prn_f = np.tile(prns, n)
    t_f = np.repeat(week_s + tow_true, m)
    r_f = np.repeat(r, m, axis=0)
    step_f = np.repeat(step, m, axis=0)
    rho, sat, states, tau = _geometry(eph, prn_f, t_f, r_f)
    rho_plus, _, plus, _ = _geometry(eph, prn_f, t_f + _DOPPLER_STEP_S, r_f + step_f, tau)
    rho_minus, _, minus, _ = _geometry(eph, prn_f, t_f - _DOPPLER_STEP_S, r_f - step_f, tau)
    rate = (rho_plus - rho_minus) / (2 * _DOPPLER_STEP_S)
    # one-sided where the step reaches another ephemeris record (its orbit jumps)
    after, before = plus.record != states.record, minus.record != states.record
    rate[after] = ((rho - rho_minus) / _DOPPLER_STEP_S)[after]
    rate[before] = ((rho_plus - rho) / _DOPPLER_STEP_S)[before]
    az, el = np.full(n * m, np.nan), np.full(n * m, np.nan)
    tropo, iono = np.zeros(n * m), np.zeros(n * m)
    tropo_err, iono_err = common
    for k in range(n):
        s = slice(k * m, (k + 1) * m)
        ok = states.valid[s]
        if not ok.any():
            continue
        a_k, e_k = azel(r[k], sat[s][ok])
        az[s][ok], el[s][ok] = a_k, e_k
        lat, lon, h = np.radians(llh[k, 0]), np.radians(llh[k, 1]), float(llh[k, 2])
        tropo[s][ok] = saastamoinen_m(float(lat), h, e_k) * (1.0 + tropo_err)
        if eph.iono_alpha is not None and eph.iono_beta is not None:
            delay = klobuchar_s(float(t_f[k * m]), float(lat), float(lon), a_k, e_k,
                                eph.iono_alpha, eph.iono_beta)  # fmt: skip
            iono[s][ok] = SPEED_OF_LIGHT * delay * (1.0 + iono_err[prns[ok]])
    shape = (n, m)
    el2, az2 = el.reshape(shape), az.reshape(shape)
    visible = np.nan_to_num(el2, nan=-1.0) >= np.radians(p.gnss_mask_deg)
    segs = [c for c in p.canyon if c.platform in ("", pid)]
    visible = _canyon_mask(visible, el2, t_rel, segs)
    rng = named_rng(seed, f"gnss-noise:{pid}")
    sin_el = np.sin(np.clip(np.nan_to_num(el2), np.radians(1.0), None))
    cn0 = 32.0 + 16.0 * sin_el + rng.normal(0.0, 1.0, shape)
    scale = 10.0 ** ((45.0 - cn0) / 20.0)
    noise = rng.normal(0.0, 1.0, shape) * p.gnss_code_sigma_m * scale
    e_dop = rng.normal(0.0, 1.0, shape) * p.gnss_doppler_sigma_hz * scale
    e_phase = rng.normal(0.0, 1.0, shape) * _PHASE_SIGMA_CYCLES * scale
    mp_rng = named_rng(seed, f"gnss-multipath:{pid}")
    unit = np.column_stack([gauss_markov(n, dt, 1.0, p.gnss_multipath_tau_s, mp_rng) for _ in prns])
    multipath = unit * p.gnss_multipath_m / sin_el
    amb, lli = _arcs(visible, named_rng(seed, f"gnss-ambiguity:{pid}"))
    rho2, clk = rho.reshape(shape), SPEED_OF_LIGHT * states.clock_l1_s.reshape(shape)
    tro2, ion2 = tropo.reshape(shape), iono.reshape(shape)
    rx = SPEED_OF_LIGHT * bias[:, None]
    code = rho2 + rx - clk + tro2 + ion2 + multipath + noise
    carrier = (rho2 + rx - clk + tro2 - ion2) / L1_WAVELENGTH_M + amb + e_phase
    rx_rate = SPEED_OF_LIGHT * (drift[:, None] - states.clock_drift_sps.reshape(shape))
    doppler = -(rate.reshape(shape) + rx_rate) / L1_WAVELENGTH_M + e_dop
    hide = ~visible
    for arr in (code, carrier, doppler, cn0):
        arr[hide] = np.nan
    used = visible.any(axis=0)
    obs = ObsTable(
        marker=pid,
        approx_ecef_m=tuple(float(v) for v in r[0]),  # type: ignore[arg-type]
        interval_s=dt,
        time_gpst_s=t_tag,
        prn=prns[used],
        code_m=code[:, used],
        doppler_hz=doppler[:, used],
        cn0_dbhz=cn0[:, used],
        phase_cycles=carrier[:, used],
        lli=lli[:, used],
    )
    tow = p.start_tow_s + t_rel
    clock = pd.DataFrame(
        {
            "time": tow,
            "platform": pid,
            "clock_bias_m": SPEED_OF_LIGHT * bias,
            "clock_drift_mps": SPEED_OF_LIGHT * drift,
        }
    )
    kk, jj = np.nonzero(visible)
    terms = {
        "time": tow[kk], "platform": pid, "prn": prns[jj],
        "elevation_deg": np.degrees(el2[kk, jj]), "azimuth_deg": np.degrees(az2[kk, jj]),
        "cn0_dbhz": cn0[kk, jj], "range": rho2[kk, jj], "sat_clock": clk[kk, jj],
        "tropo": tro2[kk, jj], "iono": ion2[kk, jj], "multipath": multipath[kk, jj],
        "noise": noise[kk, jj],
    }  # fmt: skip
    return obs, clock, pd.DataFrame(terms)


def add_gnss_obs(sim: Simulation) -> Simulation:
    """``sim`` with simulated GPS observations of every platform (``gnss_obs``; else
    ``sim`` itself)."""
    p = sim.truth.params
    if not p.gnss_obs:
        return sim
    _check_canyon(p, set(sim.truth.trajectories))
    eph = load_ephemerides(p)
    t0 = p.gps_week * 604800.0 + p.start_tow_s
    near = (eph.toe_gpst_s > t0 - 7300.0) & (eph.toe_gpst_s < t0 + p.duration_s + 7300.0)
    flown = eph.select(near & (eph.health == 0))  # the records that can serve the session
    prns = np.unique(flown.prn).astype(np.int64)
    tropo_err = float(named_rng(sim.seed, "gnss-tropo").normal(0.0, p.gnss_tropo_error))
    iono_err = np.zeros(max(64, int(prns.max()) + 1))
    iono_err[:] = named_rng(sim.seed, "gnss-iono").normal(0.0, p.gnss_iono_error, iono_err.size)
    obs: dict[str, ObsTable] = {}
    clocks, errors = [], []
    for pid, truth in sorted(sim.truth.trajectories.items()):
        table, clock, terms = _platform_obs(
            pid, truth, eph, prns, p, sim.seed, (tropo_err, iono_err)
        )
        obs[pid] = table
        clocks.append(clock)
        errors.append(terms)
    gnss = SimulatedGnss(
        observations=obs,
        ephemerides=eph,
        rinex_version=p.gnss_rinex_version,
        clock=pd.concat(clocks, ignore_index=True),
        errors=pd.concat(errors, ignore_index=True),
    )
    return dataclasses.replace(sim, gnss=gnss)
