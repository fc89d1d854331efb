"""An SPP solution as an RTKLIB ``.pos`` file (the layout of rnx2rtkp / rtkpost).

Geodetic form (RTKLIB manual, appendix B "solution file"): ``GPST`` calendar time,
``latitude(deg) longitude(deg) height(m)`` (WGS 84 ellipsoidal), ``Q`` (5 = single),
``ns`` (satellites used), ``sdn sde sdu`` (m, 1 sigma) and ``sdne sdeu sdun`` (the signed
square roots of the covariances, RTKLIB's convention), ``age(s) ratio`` (0 for single).
Written atomically; :func:`coopproc.io.rtklib_pos.read_pos` reads it back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coopproc import frames, timeconv
from coopproc.gnss.spp import SppSolution
from coopproc.io.outdir import write_text_atomic

__all__ = ["Q_SINGLE", "write_spp_pos"]

#: RTKLIB's quality flag of a single-point solution.
Q_SINGLE = 5


def _enu_cov(llh_deg: np.ndarray, cov_ecef: np.ndarray) -> np.ndarray:
    """(n, 3, 3) ENU covariances of ECEF covariances at each point."""
    lat, lon = np.radians(llh_deg[:, 0]), np.radians(llh_deg[:, 1])
    sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
    rot = np.empty((lat.size, 3, 3))
    rot[:, 0] = np.column_stack([-sl, cl, np.zeros_like(sl)])
    rot[:, 1] = np.column_stack([-sp * cl, -sp * sl, cp])
    rot[:, 2] = np.column_stack([cp * cl, cp * sl, sp])
    return np.asarray(rot @ cov_ecef @ np.transpose(rot, (0, 2, 1)))


def _signed_root(v: np.ndarray) -> np.ndarray:
    return np.asarray(np.sign(v) * np.sqrt(np.abs(v)))


def pos_text(sol: SppSolution, header: list[str] | None = None) -> str:
    """The text of the .pos file of ``sol`` (``header``: extra ``%`` comment lines)."""
    llh = frames.ecef2geodetic(sol.ecef_m)
    cov = _enu_cov(llh, sol.cov_ecef_m2)
    sd_e, sd_n, sd_u = (np.sqrt(np.maximum(cov[:, i, i], 0.0)) for i in range(3))
    sd_ne = _signed_root(cov[:, 1, 0])
    sd_eu = _signed_root(cov[:, 0, 2])
    sd_un = _signed_root(cov[:, 2, 1])
    cal = np.datetime_as_string(timeconv.gpst_to_calendar(np.round(sol.time_gpst_s, 3)), "ms")
    times = [s.replace("-", "/").replace("T", " ") for s in cal]
    lines = ["% program   : coopproc spp (RTKLIB .pos layout)"]
    if len(times):
        lines += [f"% obs start : {times[0]} GPST", f"% obs end   : {times[-1]} GPST"]
    lines += [
        "% pos mode  : single",
        *(f"% {h}" for h in header or []),
        "%",
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,"
        "ns=# of satellites)",
        "%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   "
        "sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio",
    ]
    for i, t in enumerate(times):
        lines.append(
            f"{t} {llh[i, 0]:14.9f} {llh[i, 1]:14.9f} {llh[i, 2]:10.4f} {Q_SINGLE:3d} "
            f"{int(sol.n_sat[i]):3d} {sd_n[i]:8.4f} {sd_e[i]:8.4f} {sd_u[i]:8.4f} "
            f"{sd_ne[i]:8.4f} {sd_eu[i]:8.4f} {sd_un[i]:8.4f} {0.0:6.2f} {0.0:6.1f}"
        )
    return "\n".join(lines) + "\n"


def write_spp_pos(path: str | Path, sol: SppSolution, header: list[str] | None = None) -> Path:
    """Write ``sol`` to ``path`` atomically (an OutputError when it cannot be written)."""
    return write_text_atomic(path, pos_text(sol, header))
