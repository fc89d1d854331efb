"""The result of ``coopproc locate`` (paper 004) and the types it is made of.

Produced by :mod:`coopproc.stages.particle` and read by :mod:`coopproc.report`
(``locate_figures``): a result type sits below both, so that a reporter reads results,
not algorithms (issue 34).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from coopproc.estimation.angles import heading_deg, wrap_deg
from coopproc.model import FloatArray

__all__ = ["DrIncrements", "LocateInputs", "LocateResult", "Mode", "Observability", "Track"]


@dataclass(frozen=True, eq=False)
class DrIncrements:
    """Eq. (3) inputs at the filter epochs ``time_s`` (length E).

    ``delta_l_m[k]`` and ``delta_phi_rad[k]`` (length E - 1) move a state from epoch k to
    k + 1: ``phi += delta_phi[k]; x += delta_l[k] cos(phi); y += delta_l[k] sin(phi)``
    (Algorithm 1, lines 7-8). ``theta_rad[k]`` is the direction of step k in the nav's own
    frame (a still step keeps the previous direction; leading still steps take the first
    moving one), so ``delta_phi[k] = theta[k] - theta[k-1]`` and ``delta_phi[0] = 0``.
    ``step_own_m`` (E - 1, 2) are the raw own-frame steps.
    """

    time_s: FloatArray
    delta_l_m: FloatArray
    delta_phi_rad: FloatArray
    theta_rad: FloatArray
    step_own_m: FloatArray

    @property
    def theta0_rad(self) -> float:
        """Own-frame direction of the first moving step (the first epoch's azimuth)."""
        return float(self.theta_rad[0]) if self.theta_rad.size else 0.0

    def heading_own_rad(self) -> FloatArray:
        """Own-frame direction at each epoch: of the step that ended there (epoch 0: step 0)."""
        if self.theta_rad.size == 0:
            return np.zeros(self.time_s.shape[0])
        return np.concatenate([self.theta_rad[:1], self.theta_rad])


@dataclass(frozen=True, eq=False)
class LocateInputs:
    """Dense per-epoch inputs: E epochs x J auxiliaries."""

    target: str
    aux: tuple[str, ...]
    time_s: FloatArray  # (E,)
    increments: DrIncrements
    range_m: FloatArray  # (E, J), NaN where the aux has no range at that epoch
    sigma_m: FloatArray  # (E, J) ranging 1-sigma
    aux_en_m: FloatArray  # (E, J, 2) east, north of each auxiliary

    @property
    def n_epochs(self) -> int:
        return int(self.time_s.shape[0])

    def first_fix(self) -> tuple[FloatArray, float]:
        """Auxiliary position (2,) and range of the first epoch's first available range."""
        j = int(np.argmax(np.isfinite(self.range_m[0])))
        return self.aux_en_m[0, j], float(self.range_m[0, j])


@dataclass(frozen=True)
class Observability:
    """Singular values of R_k for the whole run and from which epoch it is observable."""

    singular_values: tuple[float, float, float]
    observable: bool
    #: Index of the first epoch after which R_k (rows up to it) stays observable; None never.
    observable_from: int | None
    #: sigma_min / sigma_max of R_k built from the rows up to each epoch (E,).
    ratio_track: FloatArray = field(repr=False)


@dataclass(frozen=True)
class Mode:
    """One cluster: its weight, weighted mean position and circular mean azimuth (rad)."""

    weight: float
    east_m: float
    north_m: float
    phi_rad: float


@dataclass(frozen=True, eq=False)
class Track:
    """What one method estimated at every filter epoch (E epochs)."""

    method: str
    time_s: FloatArray
    east_m: FloatArray
    north_m: FloatArray
    #: Estimated azimuth at each epoch (math angle, rad).
    phi_rad: FloatArray
    #: The initial azimuth (math angle, rad) estimated at each epoch: the estimated azimuth
    #: minus the target's own-frame turn since the first epoch.
    initial_azimuth_track_rad: FloatArray
    #: Final initial-azimuth estimate (the last value of the track), math angle, rad.
    initial_azimuth_rad: float
    #: (time, (S, 2) east/north of a seeded subsample of the particles) at a few epochs.
    snapshots: tuple[tuple[float, FloatArray], ...] = ()
    #: (E, J) True where an auxiliary was rejected at that epoch (AACOPF step 3).
    rejected: np.ndarray | None = None
    #: Eq. (16) literally: the initial azimuth of the heaviest particle's lineage (rad).
    initial_azimuth_eq16_rad: float | None = None
    #: Modes of the final estimate, heaviest first (modes.find_modes; () not looked for).
    modes: tuple[Mode, ...] = ()
    #: Time until which the AACOPF kept every mode alive (None: not kept, or never
    #: separated by the geometry; see modekeep.py).
    modes_kept_until_s: float | None = None


@dataclass(frozen=True, eq=False)
class LocateResult:
    """Tables, observability and what the figures need."""

    table: pd.DataFrame  # LOCATE_COLUMNS -> locate.csv
    summary: pd.DataFrame  # LOCATE_SUMMARY_COLUMNS -> locate_summary.csv
    observability: Observability
    tracks: Mapping[str, Track]
    inputs: LocateInputs
    #: Target reference at the filter epochs (E, 2), NaN where none; None: no reference.
    reference_en_m: FloatArray | None
    #: Reference initial azimuth, heading degrees; None where it cannot be fitted.
    reference_initial_azimuth_deg: float | None
    warnings: tuple[str, ...] = ()

    def azimuth_error_track_deg(self, method: str) -> FloatArray | None:
        """Initial-azimuth error over time (degrees, signed), None without a reference."""
        if self.reference_initial_azimuth_deg is None:
            return None
        est = heading_deg(self.tracks[method].initial_azimuth_track_rad)
        return wrap_deg(est - self.reference_initial_azimuth_deg)
