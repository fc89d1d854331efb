"""Benchmark the ranging stage (paper 000: DI smoothing, distance filter, NLOS; DI and RN
methods) as ``coopproc run`` runs it, and its compiled kernels, against a filterpy loop.

The session is the simulator's ``large`` scenario (seed 0, written and read back like
``coopproc run`` reads it: staggered pair polling, 5 Hz reference); the cooperative
solution it needs comes from the fusion stage on the observed ranges, as in the chain.
Timed, each the median of ``--repeat`` runs after a warm-up (numba compiled or loaded):

- the whole stage as the chain calls it (``ranging (rn, di)`` in run.json): per pair the
  inputs (``prepare_pair``: rows, DR / CP / RN increments, reference), the DI smoothing,
  the self-calibration, the forward + backward distance filters of both methods, the
  second pass with the NLOS-masked CP DI, and the output tables;
- inside it, the compiled kernels (``smooth_di``, ``filter_distance``,
  ``filter_distance_two_way``) and ``prepare_pair``, summed over pairs;
- the peer: the same two filters as filterpy ``KalmanFilter`` objects, epoch by epoch,
  on one pair's series of the session (``--filterpy-epochs`` epochs; matrices built once
  outside the timed loop, one warm-up run). It runs neither the calibration nor the
  backward pass, so the comparison flatters filterpy.

Targets: >= 2,000,000 pair-epochs/s (issue 10) and >= 50x the filterpy loop, for the
whole stage and for the kernels.

    python benchmarks/ranging.py                   # 10 platforms x 0.5 h (45 pairs)
    python benchmarks/ranging.py --hours 4 --cache ~/.cache/coopproc-bench
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from _common import load, median_seconds, session_dir, spread, target

import coopproc.stages.ranging.stage as stage_mod
from coopproc.checks.coverage import prepare_run
from coopproc.io import read_session
from coopproc.run.config import RunConfig
from coopproc.stages.base import PositionInput, RangeInput
from coopproc.stages.ranging.table import observed_table
from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES

KERNELS = ("smooth_di", "filter_distance", "filter_distance_two_way")
PARTS = (*KERNELS, "prepare_pair", "pair_noise")


def instrument(spent: dict[str, float]) -> None:
    """Add the seconds of each of PARTS that the stage module calls into ``spent``."""
    for name in PARTS:
        func = getattr(stage_mod, name, None)
        if func is None:
            continue

        def wrapper(*a: Any, _f: Callable[..., Any] = func, _n: str = name, **k: Any) -> Any:
            start = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                spent[_n] = spent.get(_n, 0.0) + time.perf_counter() - start

        setattr(stage_mod, name, wrapper)


def filterpy_loop(p: Any, n: int) -> Callable[[], None]:
    """The DI smoothing + distance filter with NLOS test as filterpy KalmanFilters, over
    the first ``n`` epochs of one pair (``PairInputs``); every matrix built once here."""
    from filterpy.kalman import KalmanFilter

    di_dr = np.nan_to_num(p.di_dr_m[:n])
    di_cp = np.nan_to_num(p.di_cp_m[:n])
    rng_m = p.observed_m[:n]
    sigma = 0.15
    gamma = 3.0 * sigma
    q_smooth = np.array([[2.0 * 0.005**2, 0.0], [0.0, 1e-10]])
    q_dist = 0.25 * np.ones((2, 2))
    h_di = np.array([[0.0, 1.0]])
    u = di_dr.reshape(-1, 1, 1)
    z_cp = di_cp.reshape(-1, 1, 1)
    z_both = np.zeros((n, 2, 1))
    z_both[:, 0, 0] = rng_m
    r_di = np.empty((n, 1, 1))
    r_both = np.zeros((n, 2, 2))
    r_both[:, 0, 0] = sigma**2

    def run() -> None:
        smooth = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
        smooth.F = np.array([[0.0, 1.0], [0.0, 1.0]])  # I^- = u + s (eq. (4) with u_k)
        smooth.B = np.array([[1.0], [0.0]])
        smooth.H = np.array([[1.0, 0.0]])
        smooth.P = np.diag([1e-4, 1e-4])
        smooth.R = np.array([[1e-4]])
        smooth.Q = q_smooth
        dist = KalmanFilter(dim_x=2, dim_z=2)
        dist.F = np.array([[1.0, 1.0], [0.0, 1.0]])
        dist.H = np.eye(2)
        dist.x = np.array([[rng_m[0]], [0.0]])
        dist.P = np.diag([sigma**2, 1.0])
        dist.Q = q_dist
        for k in range(1, n):
            smooth.predict(u=u[k])
            y = di_cp[k] - smooth.x[0, 0]
            if abs(y) <= 3.0 * np.sqrt(smooth.P[0, 0] + smooth.R[0, 0]):
                smooth.update(z_cp[k])
            dist.predict()
            var = max(smooth.P[0, 0], 1e-8)
            if abs(rng_m[k] - dist.x[0, 0]) > gamma:  # eq. (9): NLOS, the DI alone
                r_di[k, 0, 0] = var
                dist.update(smooth.x[:1], R=r_di[k], H=h_di)
            else:
                r_both[k, 1, 1] = var
                z_both[k, 1, 0] = smooth.x[0, 0]
                dist.update(z_both[k], R=r_both[k])

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=0.5)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cache", type=Path, help="keep the simulated sessions here")
    parser.add_argument("--filterpy-epochs", type=int, default=5000)
    args = parser.parse_args()

    session, _ = prepare_run(read_session(session_dir(args.hours, args.platforms, args.cache)))
    config = RunConfig()
    fusion = POSITION_STAGES["fusion"]
    observed = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    product = fusion.run(
        PositionInput(session, "observed", observed, config.run.positions_at, want_cp=True),
        config.params_for(fusion.section),
    )
    assert product.cp is not None
    cp = product.cp[0] if config.run.cp_solution == "forward" else product.cp[1]
    stage = RANGE_STAGES["ranging"]
    params = config.params_for(stage.section)
    methods = tuple(m for m in config.pipeline.ranges if m in stage.methods)
    base = observed_table(session)
    total = len(base)
    pairs = len(session.ranges.pairs)
    print(
        f"large: {args.platforms} platforms x {args.hours:g} h, {pairs} pairs, "
        f"{total:,} pair-epochs"
    )

    def run_stage() -> object:
        return stage.run(RangeInput(session, base, cp), params, methods)

    seconds, times = median_seconds(run_stage, args.repeat)
    spent: dict[str, float] = {}
    instrument(spent)
    run_stage()  # once more, instrumented, for the breakdown
    kernels = sum(spent.get(k, 0.0) for k in KERNELS)
    rate = total / seconds
    print(
        f"ranging stage ({', '.join(methods)}), as run: {seconds:7.3f} s {rate:12,.0f} "
        f"pair-epochs/s  ({spread(times)}; {load()})"
    )
    for name in PARTS:
        if name in spent:
            print(f"  {name:<30} {spent[name]:7.3f} s  ({100 * spent[name] / seconds:4.1f} %)")
    print(
        f"  {'compiled kernels together':<30} {kernels:7.3f} s "
        f"{total / kernels:12,.0f} pair-epochs/s"
    )

    print(target("whole stage >= 2,000,000 pair-epochs/s", rate, 2e6, at_most=False))
    print(target("kernels >= 2,000,000 pair-epochs/s", total / kernels, 2e6, at_most=False))
    try:
        import filterpy  # noqa: F401
    except ImportError:
        print("filterpy KalmanFilter loop: not installed (pip install -e '.[bench]'), skipped")
        return
    first = stage_mod.prepare_pair(session, cp, params, session.ranges.pairs[0])
    n_fp = min(args.filterpy_epochs, first.time_s.shape[0])
    loop = filterpy_loop(first, n_fp)
    fp_seconds, fp_times = median_seconds(loop, args.repeat)
    theirs = (n_fp - 1) / fp_seconds
    print(
        f"filterpy KalmanFilter loop (1 pair, {n_fp:,} epochs): {fp_seconds:7.3f} s "
        f"{theirs:10,.0f} pair-epochs/s  ({spread(fp_times)}; {load()})"
    )
    print(target("whole stage >= 50x filterpy", rate / theirs, 50.0, at_most=False))
    print(target("kernels >= 50x filterpy", total / kernels / theirs, 50.0, at_most=False))


if __name__ == "__main__":
    main()
