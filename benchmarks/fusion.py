"""Benchmark the cooperative fusion as ``coopproc run`` runs it, on the simulator's session.

The session is the ``large`` scenario (seed 0) written by the simulator's writer and read
back like ``coopproc run`` reads it: nav 10 Hz, every pair ranging at 1 Hz with staggered
polling, so each of the 45 pairs of 10 platforms has its own range times and the filter
runs at every distinct time: about 45 epochs per second, 3.8 M epochs per day (not 86,400).

Timed, each the median of ``--repeat`` runs after a warm-up (numba compiled or loaded):

- the fusion stage as the chain calls it on the observed ranges (the self-calibrated
  fusion, ``want_cp``: what ``fusion (observed)`` in run.json times), and the peak RSS
  of its first full run above the RSS before it (psutil, sampled every 5 ms; a run on
  the first minute before it loads numba's cache);
  the same for the other ``[fusion] state`` beside it (with DR states the stage also runs
  the DR noise cross-validation's fusions and the ranging stage's CP fusion of its own, so
  its DR / position ratio is not issue 29's);
- per fusion: one ``fuse()`` as the stage's final fusion calls it (forward + RTS, no
  smoothed sigmas; with DR states its robust refit included), DR states and position
  state, with the compiled forward and smoother kernels timed inside it; issue 29's
  target is their ratio (<= 1.5; the target line's ratio is that over 1.5);
- ``fuse()`` forward only;
- the peer: filterpy's RTS smoother (``KalmanFilter.rts_smoother``, numpy, F = I) on
  ``--filterpy-epochs`` epochs of the same state size, matrices built once outside the
  timing, one warm-up call; reported per epoch.

Targets (issue 11): a day of 10 platforms runs in <= 120 s and <= 4 GB end to end, and a
run fuses three times (observed, rn, di); the fusion's lines project this session
linearly to 24 h (the real day: ``benchmarks/scale.py --day``).

    python benchmarks/fusion.py                    # 10 platforms x 0.25 h
    python benchmarks/fusion.py --hours 1 --platforms 10 --cache ~/.cache/coopproc-bench
"""

from __future__ import annotations

import argparse
import dataclasses
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import psutil
from _common import load, median_seconds, session_dir, spread, target

import coopproc.stages.fusion.fuse as fusion_mod
from coopproc.checks.coverage import prepare_run
from coopproc.estimation.dr_model import DR_STATES
from coopproc.io import read_session
from coopproc.run.config import RunConfig
from coopproc.stages.base import PositionInput
from coopproc.stages.fusion.dr_states import dr_followers
from coopproc.stages.registry import POSITION_STAGES

#: the forward filter and the smoother (modified Bryson-Frazier form, which re-runs each
#: block of the forward filter from its checkpoint: its time includes that re-run)
KERNELS = ("ekf_forward", "refit_checkpoints", "mbf_backward")


@contextmanager
def peak_rss() -> Iterator[list[int]]:
    """Yields [peak RSS above the start, in bytes], filled in at exit (5 ms sampling)."""
    proc = psutil.Process()
    base = proc.memory_info().rss
    peak = [base]
    done = threading.Event()

    def sample() -> None:
        while not done.wait(0.005):
            peak[0] = max(peak[0], proc.memory_info().rss)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    out = [0]
    try:
        yield out
    finally:
        done.set()
        thread.join()
        out[0] = max(peak[0], proc.memory_info().rss) - base


def instrument(timings: dict[str, list[float]]) -> None:
    """Time the compiled kernels that ``fuse`` calls (where the module still has them)."""
    for name in KERNELS:
        func = getattr(fusion_mod, name, None)
        if func is None:
            continue

        def wrapper(*a: Any, _f: Callable[..., Any] = func, _n: str = name, **k: Any) -> Any:
            start = time.perf_counter()
            result = _f(*a, **k)
            timings.setdefault(_n, []).append(time.perf_counter() - start)
            return result

        setattr(fusion_mod, name, wrapper)


def filterpy_rts(n: int, epochs: int, repeat: int) -> float:
    """Median seconds of filterpy's RTS smoother over ``epochs`` epochs of state size n."""
    from filterpy.kalman import KalmanFilter

    rng = np.random.default_rng(0)
    kf = KalmanFilter(dim_x=n, dim_z=1)
    xs = rng.normal(size=(epochs, n))
    a = rng.normal(size=(n, n)) * 0.1
    ps = np.repeat((a @ a.T + np.eye(n))[None], epochs, axis=0)
    fs = np.repeat(np.eye(n)[None], epochs, axis=0)
    qs = np.repeat((1e-4 * np.eye(n))[None], epochs, axis=0)
    seconds, _ = median_seconds(lambda: kf.rts_smoother(xs, ps, fs, qs), repeat)
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=0.25)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cache", type=Path, help="keep the simulated sessions here")
    parser.add_argument("--filterpy-epochs", type=int, default=5000)
    parser.add_argument(
        "--state",
        choices=("dr", "position"),
        default="dr",
        help="[fusion] state timed in detail; the other is timed beside it (issue 29: the "
        "DR states at most 1.5 x the time of the position-only fusion)",
    )
    args = parser.parse_args()

    session, _ = prepare_run(read_session(session_dir(args.hours, args.platforms, args.cache)))
    ranges = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    config = RunConfig()
    stage = POSITION_STAGES["fusion"]
    params = dataclasses.replace(config.params_for(stage.section), state=args.state)
    other = dataclasses.replace(params, state="position" if args.state == "dr" else "dr")
    moving = list(session.moving_platforms())
    n_state = len(moving) * params.dims
    n_dr = n_state + DR_STATES * len(dr_followers(session, moving, params))
    n_epochs = int(ranges["time"].nunique())
    print(
        f"large: {args.platforms} platforms x {args.hours:g} h, {len(ranges):,} ranges, "
        f"{n_epochs:,} epochs ({n_epochs / (args.hours * 3600):.1f}/s), "
        f"state {n_state} position / {n_dr} DR"
    )

    def run_stage(rows: pd.DataFrame = ranges, params: Any = params) -> object:
        inp = PositionInput(session, "observed", rows, config.run.positions_at, want_cp=True)
        return stage.run(inp, params)

    # numba compiles or loads its cache on the first minute, so that the peak RSS below
    # is the stage's own; the memory run is also the warm-up of the timed runs
    run_stage(ranges[ranges["time"] < ranges["time"].min() + 60.0])
    with peak_rss() as peak:
        run_stage()
    seconds, times = median_seconds(run_stage, args.repeat, warmup=0)
    run_stage(ranges[ranges["time"] < ranges["time"].min() + 60.0], other)  # warm-up
    beside, beside_times = median_seconds(lambda: run_stage(ranges, other), args.repeat, warmup=0)
    # the stage as run is not one fusion: with DR states it also runs the DR noise
    # cross-validation's fusions and the ranging stage's CP input (a position-state
    # fusion of its own), so its ratio is not the per-fusion figure
    print("fusion stage as run (observed ranges, self-calibrated, with the ranging stage's CP):")
    for state, s, ts in ((params.state, seconds, times), (other.state, beside, beside_times)):
        print(
            f"  state {state!r:<10} {s:7.2f} s  {n_epochs / s:10,.0f} epochs/s  "
            f"({spread(ts)}; {load()})"
        )
    dr_stage, pos_stage = (seconds, beside) if args.state == "dr" else (beside, seconds)
    print(f"  DR / position, stage as run:   {dr_stage / pos_stage:7.2f} x")
    print(f"  peak RSS above its start:       {peak[0] / 1e6:7.0f} MB (first full run)")

    # per fusion: one fuse() as the stage's final fusion calls it (forward + RTS, the
    # smoothed positions without sigmas; with DR states its robust refit included)
    kernels: dict[str, list[float]] = {}
    instrument(kernels)
    per_fusion: dict[str, float] = {}
    for p in (params, other):
        kernels.clear()
        fused, times = median_seconds(
            lambda p=p: fusion_mod.fuse(session, ranges, p, smoothed_sigma=False, forward=False),
            args.repeat,
        )
        per_fusion[p.state] = fused
        # each kernel's seconds per fuse(): its calls of the timed runs (not the warm-up's)
        calls = len(kernels.get("ekf_forward", [])) // (args.repeat + 1)
        inside = ", ".join(
            f"{name} {sum(kernels[name][calls:]) / max(args.repeat, 1):.2f} s"
            for name in KERNELS
            if name in kernels
        )
        print(
            f"fuse() forward + RTS, state {p.state!r:<10} {fused:7.2f} s  "
            f"{n_epochs / fused:10,.0f} epochs/s  ({spread(times)}; {load()})"
        )
        print(f"  kernels: {inside} ({calls} forward pass(es) and smoother pass(es))")
    ratio = per_fusion["dr"] / per_fusion["position"]
    print(f"  DR / position per fusion:      {ratio:7.2f} x")
    print(
        target(
            "DR states / position-only per fusion <= 1.5 x (ratio = (DR / position) / 1.5)",
            ratio,
            1.5,
            at_most=True,
        )
    )
    p = dataclasses.replace(params, smoother=False)
    kernels.clear()
    fused, times = median_seconds(lambda: fusion_mod.fuse(session, ranges, p), args.repeat)
    print(
        f"fuse() forward only, state {p.state!r}:   {fused:7.2f} s  {n_epochs / fused:10,.0f} "
        f"epochs/s  ({spread(times)}; {load()})"
    )
    if "ekf_forward" in kernels:
        k = float(np.median(kernels["ekf_forward"][1:] or kernels["ekf_forward"]))
        print(f"  {'ekf_forward kernel':<30} {k:7.2f} s  {n_epochs / k:10,.0f} epochs/s")
    kernels.clear()
    fusion_mod.fuse(session, ranges, params)
    rts = kernels.get("mbf_backward")
    n_fp = min(args.filterpy_epochs, n_epochs)
    try:
        fp = filterpy_rts(n_state, n_fp, args.repeat)
    except ImportError:  # the bench extra: pip install -e ".[bench]"
        print("filterpy rts_smoother: not installed (pip install -e '.[bench]'), skipped")
    else:
        fp_rate = n_fp / fp
        print(
            f"filterpy rts_smoother (n = {n_state}): {fp_rate:10,.0f} epochs/s on {n_fp:,} epochs"
        )
        if rts:
            ours = n_epochs / float(np.median(rts[1:] or rts))
            print(f"  smoother kernel / filterpy rts_smoother: {ours / fp_rate:.1f}x")

    day = 24.0 / args.hours
    print(f"projected to {args.platforms} x 24 h (x {day:g}, linear in duration):")
    print(
        target(
            "3 fusion stages of a day <= 120 s (whole run)", 3 * seconds * day, 120.0, at_most=True
        )
    )
    print(
        target(
            "fusion stage peak memory of a day <= 4 GB (whole run)",
            peak[0] * day / 1e9,
            4.0,
            at_most=True,
        )
    )


if __name__ == "__main__":
    main()
