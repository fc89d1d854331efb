"""Distance filter with NLOS detection and estimation (paper 000 eq. (8)-(12)): its entry point.

:func:`filter_distance` runs the filter over one pair's range epochs: it cuts the series
at restart gaps and runs the compiled per-epoch loop on each piece. :class:`KernelParams`
holds the numbers the loop needs, :class:`DistanceFilterOutput` its per-epoch output.
The loop itself (the eq. (8) prediction, the eq. (9) detection, the eq. (10)-(12)
estimation, onset back-dating, false alarms, event ends, adaptive sigma) is
:mod:`coopproc.stages.ranging.nlos_kernel`; the range-step test it applies
(:func:`range_jump`, re-exported here) is :mod:`coopproc.stages.ranging.jump`.
"""

from __future__ import annotations

import itertools
import typing
from dataclasses import dataclass

import numpy as np

from coopproc.model import FloatArray
from coopproc.stages.ranging.jump import JUMP_MIN_POINTS, range_jump
from coopproc.stages.ranging.nlos_kernel import filter_kernel
from coopproc.stages.ranging.nlos_types import FilterSeries, FilterSettings

__all__ = [
    "JUMP_MIN_POINTS",
    "DistanceFilterOutput",
    "EpochNoise",
    "KernelParams",
    "filter_distance",
    "range_jump",
]


@dataclass(frozen=True)
class KernelParams:
    """Numbers the per-epoch loop needs (built from the TOML config by ranging.py)."""

    sigma_m: float  # UWB 1-sigma; <= 0: adaptive
    initial_sigma_m: float
    gamma_sigma: float
    window_s: float
    aligned: bool
    di_accel_sigma: float
    one_shot: bool
    backdate_s: float
    onset_fraction: float
    confirm_fraction: float
    end_confirm_s: float
    end_min_epochs: int
    adaptive_n: int
    adaptive_min_n: int
    min_sigma_m: float
    suspect_epochs: int
    positive_only: bool
    max_event_s: float
    restart_gap_s: float = np.inf
    #: 1-sigma behind gamma_max of eq. (9) when it differs from the range noise (the
    #: innovation spread measured on the data, see calibration.py); <= 0: ``sigma_m``
    detect_sigma_m: float = 0.0
    #: an event whose ranges do not step up by this fraction of its estimate at its onset
    #: (:func:`range_jump`) is a dead-reckoning fault, not NLOS (0: no check)
    jump_fraction: float = 0.0
    jump_window_s: float = 5.0


@dataclass(frozen=True, eq=False)
class DistanceFilterOutput:
    """Per-epoch output of :func:`filter_distance` for one pair."""

    distance_m: FloatArray
    nlos_flag: np.ndarray  # int8 0/1
    nlos_estimate_m: FloatArray  # current estimate, 0 where none
    event: np.ndarray  # int64 event index (0, 1, ...) or -1
    step_estimate_m: FloatArray  # running estimate at estimation-window epochs, NaN else
    sigma_m: FloatArray  # UWB sigma used at each epoch
    residual_m: FloatArray  # r = L_D - D after the DI update


@dataclass(frozen=True, eq=False)
class EpochNoise:
    """Per-epoch numbers of the local calibration (coopproc.stages.ranging.local), which
    override :class:`KernelParams`' session-wide ``sigma_m`` / ``detect_sigma_m``."""

    sigma_m: FloatArray  # UWB sigma of the range update
    detect_sigma_m: FloatArray  # 1-sigma behind gamma_max of eq. (9)
    ranges_only: np.ndarray  # int8: 1 where no DI is used (a constant-velocity prediction)
    #: the accumulated dead-reckoning DI (m): the ranges-only step test fits L - motion
    motion_m: FloatArray

    def reversed(self) -> EpochNoise:
        return EpochNoise(
            self.sigma_m[::-1],
            self.detect_sigma_m[::-1],
            self.ranges_only[::-1],
            self.motion_m[::-1],
        )

    def piece(self, lo: int, hi: int) -> EpochNoise:
        return EpochNoise(
            self.sigma_m[lo:hi],
            self.detect_sigma_m[lo:hi],
            self.ranges_only[lo:hi],
            self.motion_m[lo:hi],
        )


def _constant_noise(n: int, params: KernelParams) -> EpochNoise:
    return EpochNoise(
        np.full(n, float(params.sigma_m)),
        np.full(n, float(params.detect_sigma_m)),
        np.zeros(n, dtype=np.int8),
        np.zeros(n),
    )


def filter_distance(
    time_s: FloatArray,
    range_m: FloatArray,
    di_m: FloatArray,
    di_var_m2: FloatArray,
    params: KernelParams,
    noise: EpochNoise | None = None,
) -> DistanceFilterOutput:
    """Distance filter with NLOS detection and estimation over one pair's range epochs.

    ``di_m`` is the DI observation at each epoch (NaN: none), ``di_var_m2`` its variance;
    ``noise``: per-epoch sigmas (None: ``params``' for every epoch).
    The series is cut at every gap longer than ``params.restart_gap_s`` and the filter
    restarts on the first range after it: an outage ends any event, and no distance or
    NLOS estimate is propagated across it. Event indices run on across the pieces.
    """
    t = np.ascontiguousarray(time_s, dtype=np.float64)
    if noise is None:
        noise = _constant_noise(t.shape[0], params)
    cuts = np.flatnonzero(np.diff(t) > params.restart_gap_s) + 1
    bounds = [0, *cuts.tolist(), t.shape[0]]
    pieces = []
    offset = 0
    for lo, hi in itertools.pairwise(bounds):
        piece = _filter_piece(
            t[lo:hi], range_m[lo:hi], di_m[lo:hi], di_var_m2[lo:hi], params, noise.piece(lo, hi)
        )
        if offset:
            piece.event[piece.event >= 0] += offset
        if np.any(piece.event >= 0):
            offset = int(piece.event.max()) + 1
        pieces.append(piece)
    if len(pieces) == 1:
        return pieces[0]
    return DistanceFilterOutput(
        *(np.concatenate([getattr(p, f) for p in pieces]) for f in _OUTPUT_FIELDS)
    )


_OUTPUT_FIELDS: tuple[str, ...] = (
    "distance_m",
    "nlos_flag",
    "nlos_estimate_m",
    "event",
    "step_estimate_m",
    "sigma_m",
    "residual_m",
)


#: Each setting's type as the compiled loop takes it (one signature: floats, bools, ints).
_SETTING_TYPES: dict[str, type] = typing.get_type_hints(FilterSettings)


def _settings(params: KernelParams) -> FilterSettings:
    """The loop's numbers: ``params``' fields of :class:`FilterSettings`' names, each as its
    type there (adaptive_n at least 1)."""
    values = {name: kind(getattr(params, name)) for name, kind in _SETTING_TYPES.items()}
    values["adaptive_n"] = max(values["adaptive_n"], 1)
    return FilterSettings(**values)


def _filter_piece(
    time_s: FloatArray,
    range_m: FloatArray,
    di_m: FloatArray,
    di_var_m2: FloatArray,
    params: KernelParams,
    noise: EpochNoise,
) -> DistanceFilterOutput:
    """:func:`filter_distance` over a piece of series without restart gaps."""
    f64 = np.float64
    series = FilterSeries(
        np.ascontiguousarray(time_s, dtype=f64),
        np.ascontiguousarray(range_m, dtype=f64),
        np.ascontiguousarray(di_m, dtype=f64),
        np.ascontiguousarray(di_var_m2, dtype=f64),
        np.ascontiguousarray(noise.sigma_m, dtype=f64),
        np.ascontiguousarray(noise.detect_sigma_m, dtype=f64),
        np.ascontiguousarray(noise.ranges_only, dtype=np.int8),
        np.ascontiguousarray(noise.motion_m, dtype=f64),
    )
    d, flag, est, event, step, sigma, resid = filter_kernel(series, _settings(params))
    return DistanceFilterOutput(
        distance_m=d,
        nlos_flag=flag,
        nlos_estimate_m=est,
        event=event,
        step_estimate_m=step,
        sigma_m=sigma,
        residual_m=resid,
    )
