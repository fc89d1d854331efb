"""What the distance filter's compiled loop (:mod:`coopproc.stages.ranging.nlos_kernel`)
takes: one pair's series and the loop's numbers, each a ``NamedTuple`` (a tuple to numba)
instead of 27 positional arguments (issue 34 part 1)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from coopproc.model import FloatArray

__all__ = ["FilterSeries", "FilterSettings"]


class FilterSeries(NamedTuple):
    """One pair's piece, one value per range epoch: times, ranges (NaN: rejected), the
    smoothed DI and its variance, the known UWB sigma (<= 0: adaptive), the sigma behind
    gamma_max (<= 0: the UWB sigma), whether the epoch's calibration window is
    ranges-only (int8), and the dead-reckoning motion along the pair (step_fit)."""

    t: FloatArray
    rng: FloatArray
    di: FloatArray
    di_var: FloatArray
    sigma_known: FloatArray
    detect_sigma: FloatArray
    ranges_only: np.ndarray
    motion: FloatArray


class FilterSettings(NamedTuple):
    """The loop's numbers: the fields of :class:`~coopproc.stages.ranging.nlos.KernelParams`
    that the compiled loop reads, by the same names, each as this type (``nlos._settings``
    copies them by name): the initial sigma, gamma_max's factor, the estimation window, the
    transition convention, the DI noise, RN's one-shot estimate, onset back-dating, the
    false-alarm and end rules, the adaptive sigma, suspects, the sign rule, the longest
    event and the range-step test."""

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
    jump_fraction: float
    jump_window_s: float
