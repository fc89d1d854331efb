"""GPS measurement models of the tightly coupled filter (paper 002 eq. 9-11) and DOP.

The filter itself (:mod:`coopproc.stages.gnss.tight_filter`) works in the session's
local ENU frame; this module gives it, per receiver epoch and at the filter's predicted
position, everything the pseudorange and Doppler rows need:

- :func:`prepare`: the satellite states of every observation row, once per receiver
  (transmission time t_tx = t_rx - P / c - dt_sv as in :mod:`coopproc.gnss.spp`;
  broadcast orbit, clock with relativity and TGD, :mod:`coopproc.gnss.ephemeris`);
- :func:`epoch_model`: for one epoch at a receiver position, the unit line-of-sight
  vectors in ENU, elevations, the modelled pseudorange without the receiver clock
  ``rho - c (dt_sv - TGD) + I + T`` (rho with the earth's rotation during the signal
  travel, first order; I Klobuchar, T Saastamoinen, :mod:`coopproc.gnss.corrections`),
  its variance (elevation weighting, :func:`~coopproc.gnss.corrections.code_variance_m2`),
  the observed range rate ``-lambda D`` and its model without the receiver drift
  ``u . (v_sv - v_r) - c dt_sv'`` (plus the rotation term's rate);
- :func:`pdop`: the position DOP of unit vectors, with rows of UWB ranges (no clock
  column) added when given (paper 002 Fig. 4).

Design matrices: d P / d r_enu = -u_enu, d P / d (c dt_r) = 1; d(-lambda D) / d v_enu =
-u_enu, d(-lambda D) / d (c dt_r') = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.frames import WGS84_A, WGS84_E2
from coopproc.gnss.corrections import (
    CodeErrorModel,
    azel,
    code_variance_m2,
    klobuchar_s,
    saastamoinen_m,
)
from coopproc.gnss.ephemeris import OMEGA_E_DOT, SPEED_OF_LIGHT, geometric_range, satellite_states
from coopproc.gnss.receiver import GnssReceiver
from coopproc.gnss.rinex_write import L1_WAVELENGTH_M
from coopproc.gnss.spp import CODE_L1
from coopproc.model import FloatArray

__all__ = [
    "DOPPLER_L1",
    "EpochModel",
    "GnssEpochs",
    "LocalFrame",
    "epoch_model",
    "local_frame",
    "pdop",
    "prepare",
]

#: L1 Doppler observations in order of preference (RINEX 3 and RINEX 2 names).
DOPPLER_L1 = ("D1C", "D1", "D1W", "D1P", "D1X")


@dataclass(frozen=True)
class LocalFrame:
    """The session's ENU frame: ``ecef = ecef0 + rot.T @ enu`` (rows of ``rot``: the
    east, north, up unit vectors in ECEF)."""

    ecef0: FloatArray
    rot: FloatArray
    lat_rad: float
    lon_rad: float
    height_m: float

    def to_ecef(self, enu: FloatArray) -> FloatArray:
        return self.ecef0 + self.rot.T @ enu


def local_frame(origin_llh_deg: tuple[float, float, float]) -> LocalFrame:
    """The ENU frame at a geodetic origin (deg, deg, m; WGS 84)."""
    lat, lon = np.radians(origin_llh_deg[0]), np.radians(origin_llh_deg[1])
    h = float(origin_llh_deg[2])
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    ecef0 = np.array(
        [
            (n + h) * np.cos(lat) * np.cos(lon),
            (n + h) * np.cos(lat) * np.sin(lon),
            (n * (1.0 - WGS84_E2) + h) * np.sin(lat),
        ]
    )
    sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
    rot = np.array([[-sl, cl, 0.0], [-sp * cl, -sp * sl, cp], [cp * cl, cp * sl, sp]])
    return LocalFrame(ecef0, rot, float(lat), float(lon), h)


@dataclass(frozen=True)
class GnssEpochs:
    """A receiver's usable GPS L1 rows with their satellite states, by epoch.

    Epoch k's rows are ``start[k]:start[k + 1]``; ``time_s`` session time, ``gpst_s``
    receiver epoch (GPST); ``rate_mps`` = -lambda D (NaN without Doppler);
    ``sat_clock_m`` = c (dt_sv - TGD); ``sat_drift_mps`` = c dt_sv'.
    """

    time_s: FloatArray
    gpst_s: FloatArray
    start: NDArray[np.int64]
    prn: NDArray[np.int64]
    code_m: FloatArray
    rate_mps: FloatArray
    sat_pos: FloatArray
    sat_vel: FloatArray
    sat_clock_m: FloatArray
    sat_drift_mps: FloatArray
    iono_alpha: tuple[float, float, float, float] | None
    iono_beta: tuple[float, float, float, float] | None

    def __len__(self) -> int:
        return int(self.time_s.shape[0])


def prepare(receiver: GnssReceiver) -> GnssEpochs:
    """The satellite states of every usable row of ``receiver`` (GPS, L1 code in range,
    ephemeris valid)."""
    obs, eph = receiver.obs, receiver.eph
    code = obs.code(CODE_L1)
    doppler = obs.code(DOPPLER_L1)
    use = (obs.system == "G") & np.isfinite(code) & (code > 1.5e7) & (code < 3.5e7)
    rows = np.flatnonzero(use)
    t_rx = obs.epoch_gpst_s[obs.epoch_index[rows]]
    t_tx = t_rx - code[rows] / SPEED_OF_LIGHT
    first = satellite_states(eph, obs.prn[rows], t_tx)
    states = satellite_states(eph, obs.prn[rows], t_tx - np.nan_to_num(first.clock_l1_s))
    ok = states.valid
    rows = rows[ok]
    m = obs.epoch_gpst_s.shape[0]
    start = np.searchsorted(obs.epoch_index[rows], np.arange(m + 1)).astype(np.int64)
    return GnssEpochs(
        time_s=receiver.epoch_time_s,
        gpst_s=obs.epoch_gpst_s,
        start=start,
        prn=obs.prn[rows].astype(np.int64),
        code_m=code[rows],
        rate_mps=-L1_WAVELENGTH_M * doppler[rows],
        sat_pos=states.pos_ecef_m[ok],
        sat_vel=states.vel_ecef_mps[ok],
        sat_clock_m=SPEED_OF_LIGHT * (states.clock_s[ok] - states.tgd_s[ok]),
        sat_drift_mps=SPEED_OF_LIGHT * states.clock_drift_sps[ok],
        iono_alpha=eph.iono_alpha,
        iono_beta=eph.iono_beta,
    )


@dataclass(frozen=True)
class EpochModel:
    """One epoch's satellites at a receiver position (see the module docstring)."""

    prn: NDArray[np.int64]
    los_enu: FloatArray
    el: FloatArray
    code_obs_m: FloatArray
    code_model_m: FloatArray
    code_var_m2: FloatArray
    rate_obs_mps: FloatArray
    rate_model_mps: FloatArray


def epoch_model(
    ep: GnssEpochs,
    k: int,
    frame: LocalFrame,
    enu: FloatArray,
    vel_enu: FloatArray,
    mask_deg: float = 10.0,
    errors: CodeErrorModel | None = None,
) -> EpochModel:
    """Epoch ``k`` of ``ep`` at the receiver position ``enu`` moving at ``vel_enu``;
    satellites below ``mask_deg`` left out."""
    sel = slice(int(ep.start[k]), int(ep.start[k + 1]))
    x = frame.to_ecef(enu)
    v = frame.rot.T @ vel_enu
    sat, sv = ep.sat_pos[sel], ep.sat_vel[sel]
    rho, u = geometric_range(sat, x)
    az, el = azel(x, sat, (frame.lat_rad, frame.lon_rad))
    keep = el >= np.radians(mask_deg)
    height = frame.height_m + float(enu[2])
    iono = np.zeros_like(rho)
    if ep.iono_alpha is not None and ep.iono_beta is not None:
        iono = SPEED_OF_LIGHT * klobuchar_s(
            float(ep.gpst_s[k]), frame.lat_rad, frame.lon_rad, az, el, ep.iono_alpha, ep.iono_beta
        )
    tropo = saastamoinen_m(frame.lat_rad, height, el)
    var = code_variance_m2(el, iono, True, errors)
    rate_model = (
        np.einsum("ij,ij->i", u, sv - v[None, :])
        + OMEGA_E_DOT * (sv[:, 0] * x[1] - sv[:, 1] * x[0]) / SPEED_OF_LIGHT
        - ep.sat_drift_mps[sel]
    )
    return EpochModel(
        prn=ep.prn[sel][keep],
        los_enu=(u @ frame.rot.T)[keep],
        el=el[keep],
        code_obs_m=ep.code_m[sel][keep],
        code_model_m=(rho - ep.sat_clock_m[sel] + iono + tropo)[keep],
        code_var_m2=var[keep],
        rate_obs_mps=ep.rate_mps[sel][keep],
        rate_model_mps=rate_model[keep],
    )


def pdop(los_enu: FloatArray, uwb_units: FloatArray | None = None) -> float:
    """Position DOP of satellites (unit vectors receiver -> satellite, ENU; a clock
    column) plus UWB ranges (unit vectors to the ranged points, no clock column); NaN
    when the geometry does not fix position and clock (paper 002 Fig. 4)."""
    g = np.column_stack([-los_enu, np.ones(los_enu.shape[0])])
    if uwb_units is not None and uwb_units.size:
        g = np.vstack([g, np.column_stack([-uwb_units, np.zeros(uwb_units.shape[0])])])
    normal = g.T @ g
    if g.shape[0] < 4 or np.linalg.cond(normal) > 1e12:
        return float("nan")
    q = np.linalg.inv(normal)
    return float(np.sqrt(np.trace(q[:3, :3])))
