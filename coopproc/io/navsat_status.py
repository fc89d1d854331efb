"""RTKLIB Q <-> ``sensor_msgs/NavSatFix`` status, both ways (docs/formats.md, "NavSatFix").

``NavSatStatus.status`` says which augmentation a fix used: -1 NO_FIX, 0 FIX (no
augmentation), 1 SBAS_FIX, 2 GBAS_FIX (ground-based: DGPS and RTK). It has no fixed /
float distinction: receiver drivers report RTK fixed, RTK float and DGPS alike as
GBAS_FIX. Reading a NavSatFix from any recorder (:func:`navsat_quality`):

======================  ==========================================================
status                  Q
======================  ==========================================================
2 GBAS_FIX              1 (fixed), with one note per channel: it may be float
1 SBAS_FIX              3 (SBAS)
0 FIX                   5 (single)
-1 NO_FIX, -2, other    no position: the epoch is left out (one note per channel)
======================  ==========================================================

coopproc's own encoding (:func:`navsat_status`, what ``write_mcap`` writes) keeps the
status standard (Q 1, 2, 4 -> 2; 3 -> 1; 5, 6 -> 0; else -1) and puts the exact Q in the
high byte of ``status.service`` (``SERVICE_GPS | Q << 8``), which the standard service
bits (GPS 1, GLONASS 2, COMPASS 4, GALILEO 8) never use. A high byte 1..6 whose Q the
status agrees with is read as the Q, so fixed and float round-trip exactly.

The covariance does not decide Q: drivers scale it in their own ways (and RTK float
sigmas overlap fixed ones), so a threshold would decide silently; the note gives the
median horizontal sigma for the user to judge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["NAVSAT_TO_Q", "Q_TO_NAVSAT", "NavsatQuality", "navsat_quality", "navsat_status"]

#: RTKLIB Q -> NavSatStatus status (RTK fixed, RTK float and DGPS are all GBAS_FIX).
Q_TO_NAVSAT = {1: 2, 2: 2, 3: 1, 4: 2, 5: 0, 6: 0}
#: NavSatStatus status -> RTKLIB Q for a NavSatFix without coopproc's exact Q.
NAVSAT_TO_Q = {2: 1, 1: 3, 0: 5}
#: ``status.service`` bit of GPS (sensor_msgs/NavSatStatus SERVICE_GPS).
SERVICE_GPS = 1
_NAMES = {2: "GBAS_FIX", 1: "SBAS_FIX", 0: "FIX", -1: "NO_FIX", -2: "UNKNOWN"}


def navsat_status(quality: int | None) -> tuple[int, int]:
    """``(status, service)`` of a reference epoch of RTKLIB Q ``quality`` (None: Q 1)."""
    q = 1 if quality is None else int(quality)
    status = Q_TO_NAVSAT.get(q, -1)
    return status, SERVICE_GPS | (q << 8 if status >= 0 else 0)


@dataclass(frozen=True)
class NavsatQuality:
    """Q of every message of a NavSatFix channel, the messages kept, and the notes."""

    #: RTKLIB Q per message (0 where there is no fix).
    quality: NDArray[np.int64]
    #: Messages with a fix (status >= 0): the others hold no position.
    keep: NDArray[np.bool_]
    notes: list[str]


def navsat_quality(
    status: NDArray[np.int64],
    service: NDArray[np.int64],
    sigma_h: NDArray[np.float64] | None = None,
    where: str = "",
) -> NavsatQuality:
    """Read a NavSatFix channel's ``status.status`` / ``status.service`` as RTKLIB Q.

    ``sigma_h``: horizontal 1-sigma per message (for the note), None when not given.
    """
    status = np.asarray(status, dtype=np.int64)
    exact = (np.asarray(service, dtype=np.int64) >> 8) & 0xFF
    generic = np.zeros(status.size, dtype=np.int64)
    for s, q in NAVSAT_TO_Q.items():
        generic[status == s] = q
    agrees = np.zeros(status.size, dtype=bool)
    for q, s in Q_TO_NAVSAT.items():
        agrees |= (exact == q) & (status == s)
    keep = status >= 0
    notes: list[str] = []
    dropped = int(status.size - keep.sum())
    if dropped:
        kinds = ", ".join(
            f"{_NAMES.get(int(s), 'status')} ({int(s)})" for s in np.unique(status[~keep])
        )
        notes.append(
            f"{where}: {dropped} of {status.size} NavSatFix messages without a fix "
            f"({kinds}) left out"
        )
    unsure = (status == 2) & ~agrees
    if unsure.any():
        spread = ""
        if sigma_h is not None and np.isfinite(sigma_h[unsure]).any():
            spread = (
                f" (median horizontal sigma {float(np.nanmedian(sigma_h[unsure])):.3f} m "
                "from position_covariance)"
            )
        notes.append(
            f"{where}: NavSatFix status cannot tell RTK fixed from float: "
            f"{int(unsure.sum())} GBAS_FIX (2) epochs read as Q=1 (fixed){spread}; "
            "if the receiver reports float solutions as GBAS_FIX too, give the reference "
            "as RTKLIB .pos or as ref_<ID>.csv with a quality column"
        )
    return NavsatQuality(np.where(agrees, exact, generic), keep, notes)
