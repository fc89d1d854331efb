"""Each platform's navigation as the ranging stage's pairs read it, prepared once.

Every pair interpolates both platforms' navigation positions at its range epochs and at
the middle of its intervals, and their velocities there (:func:`~.pair.prepare_pair`).
Done pair by pair, each of the P (P - 1) / 2 pairs copies both platforms' whole position
columns for ``np.interp`` and differentiates their whole trajectories again (at a day of
10 platforms: 90 central differences of 864,000 samples, 6 s of the stage's 19 s).
:class:`PlatformTracks` keeps, per platform, its contiguous position columns and its
velocity columns (:func:`~.rn.velocity_columns`) from its first pair to its last, then
drops them. The values are those of :meth:`Trajectory.interpolate` and
:func:`~.rn.platform_velocity`, element by element (``np.interp`` of the same numbers).
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from coopproc.errors import StageError
from coopproc.model import FloatArray, Session, Trajectory, pair_members
from coopproc.stages.ranging.config import RangingConfig
from coopproc.stages.ranging.rn import columns_at, velocity_columns
from coopproc.stages.ranging.table import platform_positions

__all__ = ["PlatformTracks"]


class PlatformTracks:
    """Navigation positions and velocities of the platforms of ``pairs`` (their order of
    use), each platform's columns kept until :meth:`done` was called for its last pair."""

    def __init__(
        self,
        session: Session,
        config: RangingConfig,
        pairs: Sequence[str],
        corrected: Mapping[str, Trajectory] | None = None,
    ) -> None:
        self._session = session
        self._config = config
        self._corrected = dict(corrected or {})
        self._left = Counter(p for pair in pairs for p in pair_members(pair))
        self._positions: dict[str, list[FloatArray]] = {}
        self._velocities: dict[str, list[FloatArray]] = {}
        self._lock = threading.Lock()

    def _fixed(self, platform: str) -> bool:
        info = self._session.platforms.get(platform)
        return info is not None and info.role == "anchor" and info.position_enu_m is not None

    def _nav(self, platform: str) -> Trajectory:
        traj = self._session.nav.get(platform)
        if traj is None:
            raise StageError(f"ranging: no navigation for platform '{platform}'")
        return traj

    def positions(self, platform: str, time_s: FloatArray, corrected: bool = False) -> FloatArray:
        """``platform``'s navigation positions at ``time_s`` (an anchor: its position);
        ``corrected``: its navigation corrected by the fusion's DR states where it has them
        (:mod:`~coopproc.stages.shared.dr_corrected`), the DR DI's input."""
        if self._fixed(platform) or platform not in self._session.nav:
            return platform_positions(
                self._session, self._session.nav, platform, time_s, "navigation", True
            )
        key = platform
        traj = self._session.nav[platform]
        if corrected and platform in self._corrected:
            key, traj = platform + "\0corrected", self._corrected[platform]
        columns = self._positions.get(key)
        if columns is None:
            columns = [np.ascontiguousarray(traj.enu_m[:, a]) for a in range(3)]
            self._positions[key] = columns
        return columns_at(traj, columns, time_s)

    def measured_velocity(self, platform: str) -> bool:
        """True when :meth:`velocity` reads ``platform``'s nav velocity columns (an INS or
        GNSS/INS velocity), not differences of its positions."""
        if self._fixed(platform) or platform not in self._session.nav:
            return False
        traj = self._session.nav[platform]
        return self._config.rn.velocity == "nav" and traj.vel_enu_mps is not None

    def velocity(self, platform: str, time_s: FloatArray) -> FloatArray:
        """``platform``'s velocity at ``time_s`` (an anchor at a fixed position: zeros)."""
        if self._fixed(platform):
            return np.zeros((time_s.shape[0], 3))
        traj = self._nav(platform)
        if self._config.rn.velocity == "difference" and traj.vel_enu_mps is not None:
            traj = replace(traj, vel_enu_mps=None)
        columns = self._velocities.get(platform)
        if columns is None:
            columns = velocity_columns(traj)
            self._velocities[platform] = columns
        return columns_at(traj, columns, time_s)

    def done(self, pair: str) -> None:
        """``pair`` is prepared: its platforms' columns go after their last pair (pairs
        may be prepared in several threads: the count is kept under a lock; a column
        asked for again after it went is made again, the same numbers)."""
        with self._lock:
            for platform in pair_members(pair):
                self._left[platform] -= 1
                if self._left[platform] <= 0:
                    self._positions.pop(platform, None)
                    self._positions.pop(platform + "\0corrected", None)
                    self._velocities.pop(platform, None)
