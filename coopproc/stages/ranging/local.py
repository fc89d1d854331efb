"""The ranging noise and the smooth-or-lean-on-ranges decision, per calibration window.

Until issue 30 every pair got one white-noise figure, one DI growth, one detection
threshold and one pass-through decision for its whole session (calibration.py). On long
recordings that switched the method off (the simulator's `large` scenario: pass-through on
0 of 45 pairs at 1 h, on all 45 at 24 h, where DI found 0 of 500 events), and the answer
for the first minutes changed with what came after them. Here the same estimates are made
over consecutive windows of ``window_s`` seconds, on a grid fixed at the pair's first range,
each from its own window's data only (the declared sigma as the prior), and applied to that
window: a stretch of data gets the same numbers whether the recording stops after it or
goes on for a day.

Per window:

1. the white range noise sigma_w: the smaller of :func:`white_sigma` of the ranges alone and
   of ``L - cumsum(I_DR)``, the ranges less the pair's dead-reckoning DI. Neither contains
   the cooperative solution, which was fused from these very ranges (issue 30: with the
   smoothed DI, whose CP part copies the ranges, the estimate fell from 0.079 m at 10 min
   to 0.045 m at 24 h for a true 0.080 m);
2. the growth q of ``L - cumsum(I)`` for the DI ``I`` the filter uses (:func:`pair_noise`
   beyond sigma_w): the filter's DI process noise is at least ``q dt``;
3. the steady-state gain of the range update (:func:`steady_gain`). Above
   ``passthrough_gain`` the DI adds too little to smooth the ranges: the window is
   **ranges-only**. There the filter gets no DI (its prediction is a constant-velocity
   model of the ranges themselves), the output is the ranges less the NLOS estimates, and
   detection and estimation go on from the ranges alone (the estimate is the ranges' own
   step at the onset, :func:`coopproc.stages.ranging.jump.range_jump`): the method is
   never silently off;
4. the innovation spread of a run without detection, combined with the declared sigma as
   a prior, times gamma_sigma: gamma_max of eq. (9) (plus q M / 3 for the DI's error over
   the estimation window M, as calibration.py explains).

A window with too few ranges for an estimate takes the previous window's numbers (the
first: the declared sigma, else the session-wide estimate). ``window_s = 300`` s: 300
ranges at 1 Hz put the MAD sigma within about 6 % (1-sigma), and five minutes is shorter
than the drift of noise the shared real recordings show (TIERS, 64 s, is one window; the
simulator's `large` scenario, 24 h, 288).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from coopproc.estimation.sigma_prior import posterior_sigma
from coopproc.model import FloatArray
from coopproc.stages.ranging.calibration import (
    MIN_SAMPLES,
    accumulated,
    pair_noise,
    robust_sigma,
    steady_gain,
    white_sigma,
    window_ids,
)
from coopproc.stages.ranging.nlos import EpochNoise, KernelParams, filter_distance

__all__ = ["LocalCalibration", "calibrate_windows", "window_ids"]


@dataclass(frozen=True, eq=False)
class LocalCalibration:
    """One pair's per-window calibration; ``noise`` holds it per epoch for the filter."""

    starts_s: FloatArray  # window start times (session time base)
    white_m: FloatArray  # per window
    detect_m: FloatArray
    growth_m2ps: FloatArray
    gain: FloatArray
    ranges_only: np.ndarray  # bool per window
    estimated: np.ndarray  # bool per window: from its own data (else carried over)
    noise: EpochNoise
    di_var_m2: FloatArray  # per epoch: max(given, q dt)
    di_m: FloatArray  # per epoch: the DI, NaN in ranges-only windows

    @property
    def ranges_only_fraction(self) -> float:
        """Share of the pair's epochs in ranges-only windows."""
        n = self.noise.ranges_only.shape[0]
        return float(np.count_nonzero(self.noise.ranges_only)) / n if n else 0.0


def _white(time_s: FloatArray, range_m: FloatArray, dr_di_m: FloatArray) -> float:
    alone = white_sigma(time_s, range_m)
    return float(np.fmin(alone, white_sigma(time_s, range_m - accumulated(dr_di_m))))


def calibrate_windows(
    time_s: FloatArray,
    range_m: FloatArray,
    di_m: FloatArray,
    dr_di_m: FloatArray,
    var_m2: FloatArray,
    params: KernelParams,
    *,
    window_s: float,
    declared_m: float | None,
    min_sigma_m: float,
    passthrough_gain: float,
    estimation_window_s: float,
) -> LocalCalibration | None:
    """The per-window calibration of one pair and method (see the module docstring).

    ``di_m``: the DI the filter uses; ``dr_di_m``: the dead-reckoning DI (for the white
    noise); ``var_m2``: the DI variance given. None when no window has enough data.
    """
    t = np.asarray(time_s, dtype=np.float64)
    n = t.shape[0]
    win = window_ids(t, window_s)
    count = int(win[-1]) + 1 if n else 0
    bounds = np.searchsorted(win, np.arange(count + 1))
    white = np.full(count, np.nan)
    growth = np.zeros(count)
    filled = np.asarray(range_m, dtype=np.float64)  # NaN at the rejected ranges
    for w in range(count):
        lo, hi = int(bounds[w]), int(bounds[w + 1])
        if hi - lo < MIN_SAMPLES + 2:
            continue
        sw = _white(t[lo:hi], filled[lo:hi], dr_di_m[lo:hi])
        found = pair_noise(t[lo:hi], filled[lo:hi], di_m[lo:hi], white_m=sw)
        if np.isfinite(found.white_sigma_m):
            white[w] = found.white_sigma_m
            growth[w] = found.growth_m2ps
    estimated = np.isfinite(white)
    if not estimated.any():
        return None
    # windows without an estimate: the previous window's (the first: the first estimate)
    first = int(np.flatnonzero(estimated)[0])
    for w in range(count):
        if not estimated[w]:
            src = w - 1 if w > first else first
            white[w], growth[w] = white[src], growth[src]
    white = np.fmax(white, min_sigma_m)
    dt = np.zeros(n)
    dt[1:] = np.diff(t)
    var = np.fmax(var_m2, growth[win] * dt)
    gain = np.full(count, np.nan)
    for w in range(count):
        lo, hi = int(bounds[w]), int(bounds[w + 1])
        v = var[max(lo, 1) : hi]
        v = v[np.isfinite(v)]
        if v.shape[0]:
            gain[w] = steady_gain(float(np.median(v)), float(white[w] ** 2))
    ranges_only = gain > passthrough_gain
    di_used = np.where(ranges_only[win], np.nan, di_m)
    epoch_white = white[win]
    motion = accumulated(dr_di_m)
    probe_noise = EpochNoise(epoch_white, epoch_white, ranges_only[win].astype(np.int8), motion)
    probe = replace(params, gamma_sigma=1e9, suspect_epochs=0, backdate_s=0.0)
    resid = filter_distance(t, range_m, di_used, var, probe, probe_noise).residual_m
    detect = np.array(white)
    for w in range(count):
        lo, hi = int(bounds[w]), int(bounds[w + 1])
        r = resid[lo:hi]
        spread = robust_sigma(r)
        d = posterior_sigma(declared_m, spread, int(np.count_nonzero(np.isfinite(r))))
        if not np.isfinite(d):
            d = detect[w - 1] if w > 0 else white[w]
        if not params.one_shot and not ranges_only[w]:
            d = float(np.sqrt(d * d + growth[w] * estimation_window_s / 3.0))
        detect[w] = max(d, white[w])
    noise = EpochNoise(epoch_white, detect[win], ranges_only[win].astype(np.int8), motion)
    return LocalCalibration(
        starts_s=t[0] + window_s * np.arange(count),
        white_m=white,
        detect_m=detect,
        growth_m2ps=growth,
        gain=gain,
        ranges_only=ranges_only,
        estimated=estimated,
        noise=noise,
        di_var_m2=var,
        di_m=di_used,
    )
