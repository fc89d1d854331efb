"""The ranging stage of paper 000: DI, DI smoothing, distance filter, NLOS (DI and RN methods).

:func:`run_ranging` processes every pair with ranges, independently:

1. the pair's range epochs (A->B and B->A alike; several ranges at one time, or the two
   directions at slightly different times, are consecutive epochs: their DI is the
   distance change over the (possibly zero) interval and eq. (7) gives it a variance
   floored at 1e-8 m^2; the distance filter takes a second range at one time as a
   second observation of the same distance: no prediction, no DI update);
2. DR DI from each platform's own navigation solution (``session.nav``) and CP DI from the
   cooperative solution ``cp`` (two passes in post-processing: the fusion with the
   observed ranges runs first, over the whole session, and its solution is differenced
   here), both interpolated at the range epochs; anchors use their fixed position;
3. the DI smoothing filter (:mod:`coopproc.stages.ranging.di`), then the distance filter with NLOS
   detection and estimation (:mod:`coopproc.stages.ranging.nlos`) for the DI method, and the same
   filter driven by the relative-velocity range rate (:mod:`coopproc.stages.ranging.rn`) with a
   one-shot NLOS estimate for the RN method.

The UWB sigma of a pair ("data"): with ``[ranging.nlos] self_calibrate`` (default) the
white noise, the DI growth and the innovation spread behind gamma_max are estimated from the
pair's own data, the declared ``session.toml [uwb] sigma`` entering as a prior
(:mod:`coopproc.stages.ranging.calibration`, :func:`_calibrated`); the DI-Based series passes the
line-of-sight ranges through when the DI is too poor to smooth them (``passthrough_gain``);
both filters run forward and backward (:mod:`coopproc.stages.ranging.twoway`). Without
self-calibration or enough epochs: the declared sigma ("session.toml"), else the adaptive
estimate ("adaptive", the median over the pair's epochs of the sigma used), else
``[ranging.nlos] default_sigma_m`` ("default").
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.memory import gives_back
from coopproc.model import (
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    FloatArray,
    Session,
    Trajectory,
)
from coopproc.stages.base import LeftOutCP
from coopproc.stages.ranging.config import RangingConfig, ranging_config_from_toml
from coopproc.stages.ranging.di import (
    SmoothedDI,
    anchored_increments,
    di_variance,
    smooth_di,
)
from coopproc.stages.ranging.local import LocalCalibration, calibrate_windows
from coopproc.stages.ranging.nlos import (
    DistanceFilterOutput,
    EpochNoise,
    KernelParams,
    filter_distance,
)
from coopproc.stages.ranging.output_columns import OutputColumns, compensated
from coopproc.stages.ranging.pair import PairInputs, kernel_params, prepare_pair
from coopproc.stages.ranging.tracks import PlatformTracks
from coopproc.stages.ranging.twoway import filter_distance_two_way
from coopproc.stages.shared.dr_corrected import corrected_by_others

__all__ = [
    "PairCalibration",
    "RangingConfig",
    "RangingOutput",
    "kernel_params",
    "ranging_config_from_toml",
    "run_ranging",
]


@dataclass(frozen=True)
class PairCalibration:
    """What one method's distance filter used for one pair, and where it came from."""

    declared_sigma_m: float  # session.toml [uwb] sigma (NaN: none)
    white_sigma_m: float  # range noise of the filter update (data estimate or declared)
    detect_sigma_m: float  # 1-sigma behind gamma_max, eq. (9)
    growth_m2ps: float  # DI process noise from the data, m^2/s (0: none)
    source: str  # "data", "session.toml", "adaptive" or "default"
    #: steady-state gain of the distance filter's range update (NaN: not computed)
    gain: float = float("nan")
    #: True: the DI adds too little (gain above passthrough_gain) in every calibration
    #: window; ranges passed through (less the NLOS found from the ranges alone)
    passthrough: bool = False
    #: share of the pair's epochs in ranges-only calibration windows (local.py)
    ranges_only_fraction: float = 0.0
    #: the per-window calibration (None: not self-calibrated)
    local: LocalCalibration | None = None
    #: where the CP DI came from: "fold k of K" (the fusion without the pair's own
    #: ranges, leave_out.py) or "all ranges" (paper 000's, and why)
    cp_source: str = "all ranges"


@dataclass(frozen=True, eq=False)
class RangingOutput:
    """Tables of the ranging stage (columns fixed by coopproc.model)."""

    ranges: pd.DataFrame  # RANGES_OUT_COLUMNS, sorted by pair then time
    di: pd.DataFrame  # DI_COLUMNS
    nlos_events: pd.DataFrame  # NLOS_EVENT_COLUMNS, method in {"di", "rn"}
    nlos_estimates: pd.DataFrame  # NLOS_ESTIMATE_COLUMNS (event numbers from 1 per pair)
    #: pair -> (UWB white-noise sigma used, "data" | "session.toml" | "adaptive" | "default")
    sigma: Mapping[str, tuple[float, str]]
    #: (pair, method) -> the self-calibration of that method's filter, method "di" or "rn"
    calibration: Mapping[tuple[str, str], PairCalibration]
    #: the RN method's (NLOS flag, NLOS estimate) at the rows of ``ranges``, when it ran
    rn_nlos: tuple[NDArray[np.int64], FloatArray] | None = None


def _events(
    pair: str, method: str, time_s: FloatArray, out: DistanceFilterOutput
) -> tuple[list[tuple[object, ...]], list[tuple[object, ...]]]:
    events: list[tuple[object, ...]] = []
    steps: list[tuple[object, ...]] = []
    ids = np.unique(out.event[out.event >= 0])
    for number, ev in enumerate(ids, start=1):
        idx = np.flatnonzero(out.event == ev)
        estimate = float(out.nlos_estimate_m[idx[-1]])
        events.append((pair, method, time_s[idx[0]], time_s[idx[-1]], idx.shape[0], estimate))
        window = idx[np.isfinite(out.step_estimate_m[idx])]
        for step, j in enumerate(window, start=1):
            steps.append((pair, method, number, step, time_s[j], float(out.step_estimate_m[j])))
    return events, steps


def _calibrated(
    p: PairInputs,
    increments: FloatArray,
    var_m2: FloatArray,
    params: KernelParams,
    config: RangingConfig,
) -> tuple[KernelParams, FloatArray, FloatArray, EpochNoise | None, PairCalibration]:
    """The filter numbers of one pair and method from its own data, per calibration window
    (local.py): (params, DI used (NaN in ranges-only windows), DI variance, per-epoch
    noise, the summary for run.json). Without enough data (or ``self_calibrate = false``)
    the given numbers stay, for every epoch.
    """
    declared = p.params.sigma_m if p.sigma_source == "session.toml" else float("nan")
    keep = PairCalibration(declared, params.sigma_m, params.sigma_m, 0.0, p.sigma_source)
    if not config.nlos.self_calibrate:
        return params, increments, var_m2, None, keep
    nlos = config.nlos
    local = calibrate_windows(
        p.time_s,
        p.kept_m,
        increments,
        p.di_dr_m,
        var_m2,
        params,
        window_s=nlos.calibration_window_s,
        declared_m=None if np.isnan(declared) else declared,
        min_sigma_m=nlos.min_sigma_m,
        passthrough_gain=nlos.passthrough_gain,
        estimation_window_s=nlos.window_s,
    )
    if local is None:
        return params, increments, var_m2, None, keep
    # eq. (11) averages eps = L - D' over M seconds of DI propagation, so the estimate
    # carries the DI error of the window's mean: for a random walk of growth q, variance
    # q M / 3. The test of eq. (9) allows for it (local.py), or DI drift reads as NLOS
    # (measured on TIERS: q M gave DI recall 0.03, nothing gave 24 % false alarms on
    # tb6-tb7, q M / 3 3.8 % at most with recall 0.86-0.90 on tb1-tb3 / tb1-tb7). The
    # one-shot RN estimate uses no window.
    fraction = local.ranges_only_fraction
    cal = PairCalibration(
        declared,
        float(np.median(local.white_m)),
        float(np.median(local.detect_m)),
        float(np.median(local.growth_m2ps)),
        "data",
        gain=float(np.nanmedian(local.gain)) if np.isfinite(local.gain).any() else np.nan,
        passthrough=fraction >= 1.0,
        ranges_only_fraction=fraction,
        local=local,
    )
    tuned = replace(params, sigma_m=cal.white_sigma_m, detect_sigma_m=cal.detect_sigma_m)
    return tuned, local.di_m, local.di_var_m2, local.noise, cal


#: One pair's DI method: the smoothed DI, the DR DI, the filter's output, its calibration.
_DiResult = tuple[SmoothedDI, FloatArray, DistanceFilterOutput, PairCalibration]


def _di_method(
    p: PairInputs, config: RangingConfig, mask: NDArray[np.bool_] | None = None
) -> _DiResult:
    """DI smoothing + distance filter; ``mask``: epochs whose CP solution is not trusted.

    At masked epochs the CP DI is not used and the DR DI is anchored (``dr_base = "cp"``)
    on the last trusted CP position propagated by dead reckoning.
    """
    di_dr, di_cp = p.di_dr_m, p.di_cp_m
    if mask is not None:
        di_cp = np.where(mask, np.nan, di_cp)
        if config.di.dr_base == "cp":
            last = np.maximum.accumulate(np.where(mask, 0, np.arange(mask.shape[0])))
            base = [cp[last] + nav - nav[last] for cp, nav in zip(p.cp_m, p.nav_m, strict=True)]
            di_dr = anchored_increments(base[0], base[1], p.nav_m[0], p.nav_m[1])
            di_dr = np.where(p.di_by_velocity, p.di_dr_m, di_dr)  # (no positions there)
    smoothed = smooth_di(
        p.time_s, di_dr, di_cp, p.var_m2, config.di, config.nlos.calibration_window_s
    )
    # R_I of eq. (8): the smoothed-DI variance, at least the configured DI error floor
    floor = di_variance(p.time_s, config.distance.di_sigma_floor_mps, 0.0, config.di.drift_scaling)
    r_i = np.fmax(smoothed.var_m2, floor)
    params, di_used, r_i, noise, cal = _calibrated(p, smoothed.di_m, r_i, p.params, config)
    if config.nlos.two_way:
        out, _ = filter_distance_two_way(p.time_s, p.kept_m, di_used, r_i, params, noise)
    else:
        out = filter_distance(p.time_s, p.kept_m, di_used, r_i, params, noise)
    if noise is not None and noise.ranges_only.any():
        # in ranges-only windows the DI would smooth the white noise by less than 1 - gain
        # of its variance, and any error of its model would cost more: the ranges pass
        # through, less the NLOS the ranges-only detection found
        own = noise.ranges_only.astype(bool)
        out = replace(out, distance_m=np.where(own, compensated(p.kept_m, out), out.distance_m))
    return smoothed, di_dr, out, cal


def _event_intervals(
    pairs: list[PairInputs], outs: Mapping[str, DistanceFilterOutput], config: RangingConfig
) -> dict[str, list[tuple[float, float]]]:
    """Per platform, the DI-method NLOS events of its pairs widened by the CP guard."""
    intervals: dict[str, list[tuple[float, float]]] = {}
    for p in pairs:
        out = outs[p.name]
        for ev in np.unique(out.event[out.event >= 0]):
            idx = np.flatnonzero(out.event == ev)
            span = (
                p.time_s[idx[0]] - config.di.cp_guard_before_s,
                p.time_s[idx[-1]] + config.di.cp_guard_after_s,
            )
            for member in p.members:
                intervals.setdefault(member, []).append(span)
    return intervals


#: Threads preparing the pairs' inputs (two pairs at a time at most: each holds its pair's
#: columns while it works).
_PREPARE_THREADS = min(2, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def _cp_source(left_out: LeftOutCP | None, pair: str) -> str:
    """PairCalibration.cp_source of ``pair``."""
    if left_out is None or not left_out.folds:
        return "all ranges"
    if pair in left_out.trajectories:
        return f"without its ranges: fold {left_out.fold[pair] + 1} of {left_out.folds}"
    why = left_out.kept.get(pair, "no fold")
    return f"all ranges ({why})"


def run_ranging(
    session: Session,
    cp: Mapping[str, Trajectory],
    config: RangingConfig,
    methods: tuple[str, ...] = ("rn", "di"),
    left_out: LeftOutCP | None = None,
    dr_states: pd.DataFrame | None = None,
) -> RangingOutput:
    """Process every pair's ranges with the DI-Based and the RN-Based methods (paper 000).

    ``methods``: which of ``rn``, ``di`` to give; the DI method always runs (its NLOS
    events mask the CP DI of the second pass), the RN filter only when asked for.
    ``left_out``: each pair's cooperative solution without its own ranges (the CP DI of
    the pairs it has; :mod:`coopproc.stages.fusion.leave_out`); None: ``cp`` for all.

    Two passes when ``[ranging.di] mask_nlos_cp`` (default): the cooperative solution was
    computed with the observed ranges, so during an NLOS event it is pulled by the NLOS
    error of every pair of the platforms involved; the second pass does not use the CP DI
    of any pair sharing a platform with a pair in a first-pass event (widened by the
    guard times), so there the smoothed DI follows the DR DI plus the DI deviation.
    """
    pairs, results = _di_passes(session, cp, config, left_out, dr_states)
    tables = OutputColumns(pairs, "rn" in methods)
    events: list[tuple[object, ...]] = []
    steps: list[tuple[object, ...]] = []
    sigma_used: dict[str, tuple[float, str]] = {}
    calibration: dict[tuple[str, str], PairCalibration] = {}
    queue = deque(pairs)
    del pairs  # each pair's inputs go once its rows are written
    for i in range(len(queue)):
        p = queue.popleft()
        found = _write_pair(i, p, results.pop(p.name), tables, config, methods, left_out)
        calibration.update(found.calibration)
        sigma_used[p.name] = found.sigma
        events.extend(found.events)
        steps.extend(found.steps)
    ranges, di = tables.frames()
    return RangingOutput(
        ranges=ranges,
        di=di,
        nlos_events=pd.DataFrame(events, columns=list(NLOS_EVENT_COLUMNS)),
        nlos_estimates=pd.DataFrame(steps, columns=list(NLOS_ESTIMATE_COLUMNS)),
        sigma=sigma_used,
        calibration=calibration,
        rn_nlos=tables.rn_nlos if "rn" in methods else None,
    )


@gives_back  # the DI passes' working arrays, before the output columns take more
def _di_passes(
    session: Session,
    cp: Mapping[str, Trajectory],
    config: RangingConfig,
    left_out: LeftOutCP | None,
    dr_states: pd.DataFrame | None,
) -> tuple[list[PairInputs], dict[str, _DiResult]]:
    """Every pair's inputs and its DI method's result (the second pass where a first-pass
    event masks the CP DI, run_ranging's docstring)."""
    # each platform's navigation columns and velocity once, shared by its pairs; the
    # pairs prepared two at a time (np.interp, most of it, releases the GIL: 6.9 -> ~4 s
    # at a day, issue 11), each by the same arithmetic, so the same arrays
    corrected = {}
    if dr_states is not None and config.di.dr_states:
        # the followers whose states other pairs' ranges fit too (dr_corrected.py)
        fixed = corrected_by_others(session, dr_states)
        corrected = {p: t for p, t in fixed.nav.items() if t is not session.nav[p]}
    tracks = PlatformTracks(session, config, session.ranges.pairs, corrected)

    def prepared(pair: str) -> PairInputs:
        own = left_out.trajectories.get(pair) if left_out is not None else None
        inputs = prepare_pair(session, cp if own is None else own, config, pair, tracks)
        tracks.done(pair)
        return inputs

    with ThreadPoolExecutor(max_workers=_PREPARE_THREADS) as pool:
        pairs = list(pool.map(prepared, session.ranges.pairs))
    results = {p.name: _di_method(p, config) for p in pairs}
    if config.di.mask_nlos_cp:
        intervals = _event_intervals(pairs, {k: v[2] for k, v in results.items()}, config)
        for p in pairs:
            mask = np.zeros(p.time_s.shape[0], dtype=bool)
            for member in p.members:
                for lo, hi in intervals.get(member, []):
                    mask |= (p.time_s >= lo) & (p.time_s <= hi)
            if mask.any():
                results[p.name] = _di_method(p, config, mask)
    return pairs, results


@dataclass(frozen=True)
class _PairRows:
    """What one pair adds to the stage's output besides its columns."""

    calibration: dict[tuple[str, str], PairCalibration]
    sigma: tuple[float, str]
    events: list[tuple[object, ...]]
    steps: list[tuple[object, ...]]


@gives_back  # the pair's RN working arrays and the last pair's inputs
def _write_pair(
    i: int,
    p: PairInputs,
    di_result: _DiResult,
    tables: OutputColumns,
    config: RangingConfig,
    methods: tuple[str, ...],
    left_out: LeftOutCP | None,
) -> _PairRows:
    """Pair ``p``'s rows into ``tables`` (row block ``i``): its DI result, RN-Based when
    asked for, their NLOS events and estimates."""
    smoothed, di_dr, di_out, di_cal = di_result
    di_cal = replace(di_cal, cp_source=_cp_source(left_out, p.name))
    calibration = {(p.name, "di"): di_cal}
    outs = {"di": di_out}
    if "rn" in methods:
        outs["rn"], calibration[(p.name, "rn")] = _rn_method(p, config)
    sigma = di_cal.white_sigma_m
    if di_cal.source == "adaptive":
        sigma = float(np.nanmedian(di_out.sigma_m))
    tables.write(i, p, smoothed, di_dr, outs)
    events: list[tuple[object, ...]] = []
    steps: list[tuple[object, ...]] = []
    for method, out in outs.items():
        ev, st = _events(p.name, method, p.time_s, out)
        events.extend(ev)
        steps.extend(st)
    return _PairRows(calibration, (sigma, di_cal.source), events, steps)


def _rn_method(
    p: PairInputs, config: RangingConfig
) -> tuple[DistanceFilterOutput, PairCalibration]:
    """The RN-Based reference method: the distance filter driven by the relative-velocity
    range rate, with a one-shot NLOS estimate at detection (paper 000 sec. 4)."""
    rn_params = replace(
        p.params, one_shot=True, backdate_s=0.0, confirm_fraction=0.0, suspect_epochs=0
    )
    rn_params, rn_inc, rn_var, noise, rn_cal = _calibrated(
        p, p.rn_m, p.rn_var_m2, rn_params, config
    )
    if config.nlos.two_way:
        rn_out, _ = filter_distance_two_way(p.time_s, p.kept_m, rn_inc, rn_var, rn_params, noise)
    else:
        rn_out = filter_distance(p.time_s, p.kept_m, rn_inc, rn_var, rn_params, noise)
    return rn_out, rn_cal
