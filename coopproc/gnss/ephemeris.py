"""GPS satellite positions, velocities and clocks from broadcast ephemerides (IS-GPS-200).

:class:`GpsEphemerides` holds the broadcast records (one array entry per record, as a
navigation file gives them; reading is :mod:`coopproc.gnss.rinex_read`'s job).
:func:`satellite_states` evaluates them for satellites ``prn`` at GPS system times of
transmission ``t_tx_gpst_s`` (seconds since the GPS epoch 1980-01-06, GPST):

- the record used for a (prn, t) is the healthy one of that satellite with the nearest
  toe; it is *valid* when ``|t - toe|`` is at most half the fit interval (fit interval
  0 or unknown = 4 h, i.e. +-2 h). Out of validity (or no record for that prn) the row
  is NaN and ``valid`` False: callers decide (the SPP drops the satellite and raises a
  one-line error when an epoch has none left);
- orbit: Kepler's equation, the harmonic corrections (cuc ... cis) and the earth-fixed
  frame at the time of transmission (IS-GPS-200 Table 20-IV); velocity by the analytic
  derivative of the same equations;
- clock: ``clock_s`` = af0 + af1 dt + af2 dt^2 + relativistic term (F e sqrtA sin E),
  dt = t - toc; ``tgd`` separately: an L1 C/A user applies ``clock_s - tgd``
  (:attr:`SatStates.clock_l1_s`, IS-GPS-200 20.3.3.3.3.2);
- earth rotation during the signal's travel (Sagnac) is not in the states (they are in
  the ECEF frame at the transmission time): :func:`rotate_to_reception` turns them into
  the frame at reception.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from coopproc.estimation.range_model import slant_ranges_units
from coopproc.model import FloatArray

__all__ = [
    "F_REL",
    "GPS_PI",
    "MU_GPS",
    "OMEGA_E_DOT",
    "SPEED_OF_LIGHT",
    "GpsEphemerides",
    "SatStates",
    "geometric_range",
    "rotate_to_reception",
    "satellite_states",
]

IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: WGS 84 earth gravitational constant for GPS (m^3/s^2), IS-GPS-200 Table 20-IV.
MU_GPS = 3.986005e14
#: WGS 84 earth rotation rate (rad/s), IS-GPS-200 Table 20-IV.
OMEGA_E_DOT = 7.2921151467e-5
#: Relativistic clock constant F = -2 sqrt(mu) / c^2 (s/m^0.5), IS-GPS-200 20.3.3.3.3.1.
F_REL = -4.442807633e-10
#: pi as IS-GPS-200 defines it for the orbit equations.
GPS_PI = 3.1415926535898
#: Speed of light (m/s), IS-GPS-200.
SPEED_OF_LIGHT = 299792458.0

_WEEK_S = 604800.0
_DEFAULT_FIT_H = 4.0


@dataclass(frozen=True)
class GpsEphemerides:
    """GPS broadcast ephemeris records, one entry per record (all arrays of length n).

    Times ``toc_gpst_s`` / ``toe_gpst_s`` are absolute GPST seconds since the GPS epoch
    (week crossovers resolved by the reader). Angles in radians (semicircles converted),
    rates in rad/s, clock terms in s, s/s, s/s^2. ``health`` 0 = healthy;
    ``fit_interval_h`` 0 = the default 4 h. ``iono_alpha`` / ``iono_beta``: the Klobuchar
    coefficients of the file header (None when absent).
    """

    prn: IntArray
    toc_gpst_s: FloatArray
    toe_gpst_s: FloatArray
    af0: FloatArray
    af1: FloatArray
    af2: FloatArray
    sqrt_a: FloatArray
    e: FloatArray
    i0: FloatArray
    omega0: FloatArray
    omega: FloatArray
    m0: FloatArray
    delta_n: FloatArray
    idot: FloatArray
    omega_dot: FloatArray
    cuc: FloatArray
    cus: FloatArray
    crc: FloatArray
    crs: FloatArray
    cic: FloatArray
    cis: FloatArray
    tgd: FloatArray
    iode: IntArray
    week: IntArray
    health: IntArray
    fit_interval_h: FloatArray
    iono_alpha: tuple[float, float, float, float] | None = None
    iono_beta: tuple[float, float, float, float] | None = None
    source: str = ""

    def __len__(self) -> int:
        return int(self.prn.shape[0])

    def select(self, mask: BoolArray | IntArray) -> GpsEphemerides:
        """The records at ``mask`` (boolean or index array), header values kept."""
        values = {
            f.name: getattr(self, f.name)[mask]
            if isinstance(getattr(self, f.name), np.ndarray)
            else getattr(self, f.name)
            for f in fields(self)
        }
        return GpsEphemerides(**values)

    @staticmethod
    def concatenate(parts: list[GpsEphemerides]) -> GpsEphemerides:
        """Records of several files in one (header values from the first that has them;
        duplicate records, same prn and toe and iode, kept once)."""
        if not parts:
            raise ValueError("no ephemerides to concatenate")
        values: dict[str, object] = {}
        for f in fields(GpsEphemerides):
            first = getattr(parts[0], f.name)
            if isinstance(first, np.ndarray):
                values[f.name] = np.concatenate([getattr(p, f.name) for p in parts])
            else:
                values[f.name] = next(
                    (getattr(p, f.name) for p in parts if getattr(p, f.name)), first
                )
        merged = GpsEphemerides(**values)  # type: ignore[arg-type]
        key = np.column_stack([merged.prn, merged.toe_gpst_s, merged.iode])
        _, keep = np.unique(key, axis=0, return_index=True)
        keep.sort()
        return merged.select(keep)


@dataclass(frozen=True)
class SatStates:
    """Satellite states at the times of transmission, ECEF frame at that time (WGS 84).

    ``pos_ecef_m`` / ``vel_ecef_mps`` (n, 3); ``clock_s`` the clock offset including the
    relativistic term (not TGD), ``clock_drift_sps`` its rate; ``relativistic_s`` the
    relativistic term alone; ``tgd_s`` the group delay; ``valid`` False where no
    ephemeris covers the time (the other fields are NaN there); ``record`` the index of
    the ephemeris record used (-1 where none).
    """

    pos_ecef_m: FloatArray
    vel_ecef_mps: FloatArray
    clock_s: FloatArray
    clock_drift_sps: FloatArray
    relativistic_s: FloatArray
    tgd_s: FloatArray
    valid: BoolArray
    record: IntArray

    @property
    def clock_l1_s(self) -> FloatArray:
        """The clock offset for an L1 C/A pseudorange: ``clock_s - tgd_s``."""
        return self.clock_s - self.tgd_s


def _select_records(
    eph: GpsEphemerides, prn: IntArray, t: FloatArray
) -> tuple[IntArray, BoolArray]:
    """Index of the healthy record of each prn with the nearest toe, and its validity."""
    n = prn.shape[0]
    record = np.full(n, -1, dtype=np.int64)
    best = np.full(n, np.inf)
    usable = eph.health == 0
    for j in np.flatnonzero(usable):
        mine = prn == eph.prn[j]
        if not mine.any():
            continue
        dt = np.abs(t - eph.toe_gpst_s[j])
        better = mine & (dt < best)
        record[better] = j
        best[better] = dt[better]
    fit = np.where(eph.fit_interval_h > 0, eph.fit_interval_h, _DEFAULT_FIT_H)
    half = np.where(record >= 0, fit[np.maximum(record, 0)] * 1800.0, 0.0)
    valid = (record >= 0) & (best <= half)
    return record, valid


def _kepler(m: FloatArray, e: FloatArray) -> FloatArray:
    """Eccentric anomaly E from M = E - e sin E (Newton iterations, to 1e-14 rad)."""
    big_e = m.copy()
    for _ in range(30):
        step = (big_e - e * np.sin(big_e) - m) / (1.0 - e * np.cos(big_e))
        big_e -= step
        if np.all(np.abs(step) < 1e-14):
            break
    return big_e


def satellite_states(eph: GpsEphemerides, prn: IntArray, t_tx_gpst_s: FloatArray) -> SatStates:
    """States of satellites ``prn`` at GPS times of transmission ``t_tx_gpst_s`` (both (n,)).

    Rows without a valid ephemeris are NaN with ``valid`` False (see the module notes).
    """
    prn = np.asarray(prn, dtype=np.int64).ravel()
    t = np.asarray(t_tx_gpst_s, dtype=np.float64).ravel()
    if prn.shape != t.shape:
        raise ValueError(f"prn {prn.shape} and times {t.shape} differ in shape")
    n = prn.shape[0]
    record, valid = _select_records(eph, prn, t)
    pos = np.full((n, 3), np.nan)
    vel = np.full((n, 3), np.nan)
    clock = np.full(n, np.nan)
    drift = np.full(n, np.nan)
    rel = np.full(n, np.nan)
    tgd = np.full(n, np.nan)
    idx = np.flatnonzero(valid)
    if idx.size:
        r = record[idx]
        out = _evaluate(eph, r, t[idx])
        pos[idx], vel[idx], clock[idx], drift[idx], rel[idx] = out
        tgd[idx] = eph.tgd[r]
    return SatStates(
        pos_ecef_m=pos,
        vel_ecef_mps=vel,
        clock_s=clock,
        clock_drift_sps=drift,
        relativistic_s=rel,
        tgd_s=tgd,
        valid=valid,
        record=np.where(valid, record, -1),
    )


def _evaluate(
    eph: GpsEphemerides, r: IntArray, t: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """IS-GPS-200 Table 20-IV for records ``r`` at times ``t`` (position, velocity,
    clock with relativity, clock drift, relativistic term)."""
    sqrt_a, e = eph.sqrt_a[r], eph.e[r]
    a = sqrt_a * sqrt_a
    n0 = np.sqrt(MU_GPS / a**3)
    tk = t - eph.toe_gpst_s[r]
    n = n0 + eph.delta_n[r]
    mk = eph.m0[r] + n * tk
    ek = _kepler(mk, e)
    sin_e, cos_e = np.sin(ek), np.cos(ek)
    one_m_ecos = 1.0 - e * cos_e
    root = np.sqrt(1.0 - e * e)
    nu = np.arctan2(root * sin_e, cos_e - e)
    phi = nu + eph.omega[r]
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    du = eph.cus[r] * s2 + eph.cuc[r] * c2
    dr = eph.crs[r] * s2 + eph.crc[r] * c2
    di = eph.cis[r] * s2 + eph.cic[r] * c2
    u = phi + du
    rk = a * one_m_ecos + dr
    ik = eph.i0[r] + di + eph.idot[r] * tk
    x_orb, y_orb = rk * np.cos(u), rk * np.sin(u)
    omega_k = (
        eph.omega0[r]
        + (eph.omega_dot[r] - OMEGA_E_DOT) * tk
        - OMEGA_E_DOT * (eph.toe_gpst_s[r] % _WEEK_S)
    )
    cos_o, sin_o = np.cos(omega_k), np.sin(omega_k)
    cos_i, sin_i = np.cos(ik), np.sin(ik)
    x = x_orb * cos_o - y_orb * cos_i * sin_o
    y = x_orb * sin_o + y_orb * cos_i * cos_o
    z = y_orb * sin_i
    # rates (the derivative of the same equations)
    ek_dot = n / one_m_ecos
    nu_dot = ek_dot * root / one_m_ecos
    phi_dot = nu_dot
    u_dot = phi_dot * (1.0 + 2.0 * (eph.cus[r] * c2 - eph.cuc[r] * s2))
    rk_dot = a * e * sin_e * ek_dot + 2.0 * phi_dot * (eph.crs[r] * c2 - eph.crc[r] * s2)
    ik_dot = eph.idot[r] + 2.0 * phi_dot * (eph.cis[r] * c2 - eph.cic[r] * s2)
    omega_k_dot = eph.omega_dot[r] - OMEGA_E_DOT
    x_orb_dot = rk_dot * np.cos(u) - y_orb * u_dot
    y_orb_dot = rk_dot * np.sin(u) + x_orb * u_dot
    vx = (
        -x_orb * omega_k_dot * sin_o
        + x_orb_dot * cos_o
        - y_orb_dot * sin_o * cos_i
        - y_orb * (omega_k_dot * cos_o * cos_i - ik_dot * sin_o * sin_i)
    )
    vy = (
        x_orb * omega_k_dot * cos_o
        + x_orb_dot * sin_o
        + y_orb_dot * cos_o * cos_i
        - y_orb * (omega_k_dot * sin_o * cos_i + ik_dot * cos_o * sin_i)
    )
    vz = y_orb_dot * sin_i + y_orb * ik_dot * cos_i
    rel = F_REL * e * sqrt_a * sin_e
    rel_dot = F_REL * e * sqrt_a * cos_e * ek_dot
    dtc = t - eph.toc_gpst_s[r]
    clock = eph.af0[r] + eph.af1[r] * dtc + eph.af2[r] * dtc * dtc + rel
    drift = eph.af1[r] + 2.0 * eph.af2[r] * dtc + rel_dot
    return (
        np.column_stack([x, y, z]),
        np.column_stack([vx, vy, vz]),
        clock,
        drift,
        rel,
    )


def rotate_to_reception(pos_ecef_m: FloatArray, travel_s: FloatArray) -> FloatArray:
    """ECEF positions at transmission expressed in the ECEF frame at reception: the
    earth turns by ``OMEGA_E_DOT * travel_s`` about z while the signal travels (Sagnac)."""
    angle = OMEGA_E_DOT * np.asarray(travel_s, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(pos_ecef_m, dtype=np.float64)
    return np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1], p[:, 2]])


def geometric_range(sat_ecef_m: FloatArray, rx_ecef_m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The pseudorange's geometric part (m) and the unit vectors from the receiver to the
    satellites: |sat - rx| (:mod:`coopproc.estimation.range_model`) plus the first-order
    term of the earth's rotation during the travel, omega_e (x_s y_r - y_s x_r) / c
    (IS-GPS-200 sec. 20.3.3.4.3.4; the SPP and the tightly coupled filters' one model)."""
    sat = np.asarray(sat_ecef_m, dtype=np.float64)
    x = np.asarray(rx_ecef_m, dtype=np.float64)
    geo, unit = slant_ranges_units(sat - x[None, :])
    return geo + OMEGA_E_DOT * (sat[:, 0] * x[1] - sat[:, 1] * x[0]) / SPEED_OF_LIGHT, unit
