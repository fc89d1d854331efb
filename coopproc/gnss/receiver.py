"""One platform's GNSS receiver as the session holds it (DATA.md "Raw sensors").

The observations of ``obs_<ID>.<yy>o`` / ``obs_<ID>.rnx`` with the session's broadcast
ephemerides (every navigation file of the session merged) and the offset that turns the
receiver's GPST epochs into session time (``session = gpst - time_offset_s``).
"""

from __future__ import annotations

from dataclasses import dataclass

from coopproc.gnss.ephemeris import GpsEphemerides
from coopproc.gnss.rinex_obs import GnssObservations
from coopproc.model import FloatArray

__all__ = ["GnssReceiver"]


@dataclass(frozen=True, eq=False)
class GnssReceiver:
    """Raw GPS observations of one platform, ready for :mod:`coopproc.gnss.tight`."""

    platform: str
    obs: GnssObservations
    eph: GpsEphemerides
    #: session time = GPST seconds since the GPS epoch - time_offset_s
    time_offset_s: float

    @property
    def epoch_time_s(self) -> FloatArray:
        """The epochs in session time."""
        return self.obs.epoch_gpst_s - self.time_offset_s
