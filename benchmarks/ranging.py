"""Benchmark of the ranging hot loops: DI smoothing (paper 000 eq. (4)-(7)) + distance
filter with NLOS detection/estimation (eq. (8)-(12)), against a per-epoch filterpy loop.

    /work/venv/bin/python benchmarks/ranging.py            # 45 pairs x 86,400 epochs
    /work/venv/bin/python benchmarks/ranging.py --quick    # 45 pairs x 8,640 epochs

The coopproc figure covers every pair and epoch; the filterpy loop (the same two filters:
a KalmanFilter with control input for the DI smoothing and one for the distance filter
with the eq. (9) threshold test) is timed on ``--filterpy-epochs`` epochs of one pair and
reported per pair-epoch (it is ~10^5 times slower; running it on 3.9 M pair-epochs would
take an hour). Targets: >= 2,000,000 pair-epochs/s and >= 50x filterpy.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from coopproc.stages.ranging.calibration import pair_noise, robust_sigma
from coopproc.stages.ranging.di import DISmoothingParams, di_variance, smooth_di
from coopproc.stages.ranging.nlos import filter_distance
from coopproc.stages.ranging.stage import RangingConfig, kernel_params
from coopproc.stages.ranging.twoway import filter_distance_two_way

#: The stage's defaults (paper 000: gamma = 3 sigma, M = 3 s), sigma 0.15 m, 60 s window.
PARAMS = kernel_params(RangingConfig(), 0.15, 0.15, 60, rn=False)


def make_pair(n: int, seed: int) -> dict[str, np.ndarray]:
    """One pair's synthetic series at 1 Hz: DR / CP DI, ranges with NLOS blocks."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=np.float64)
    true = 20.0 + 3.0 * np.sin(t / 60.0 + seed)
    di_true = np.r_[np.nan, np.diff(true)]
    di_dr = di_true + 0.004 + rng.normal(0.0, 0.003, n)
    di_cp = di_true + rng.normal(0.0, 0.01, n)
    jumps = rng.random(n) < 0.01
    di_cp[jumps] += rng.normal(0.0, 0.3, jumps.sum())
    rng_m = true + rng.normal(0.0, 0.08, n)
    for start in rng.integers(0, max(n - 30, 1), size=max(n // 3600, 1)):
        rng_m[start : start + 20] += rng.normal(0.5, 0.1, min(20, n - start))
    return {"t": t, "di_dr": di_dr, "di_cp": di_cp, "range": rng_m}


def run_coopproc(pairs: list[dict[str, np.ndarray]]) -> float:
    """Seconds for DI smoothing + distance filter + NLOS over every pair."""
    params = DISmoothingParams()
    start = time.perf_counter()
    for p in pairs:
        var = di_variance(p["t"], 0.005, 0.005, "sqrt")
        smoothed = smooth_di(p["t"], p["di_dr"], p["di_cp"], var, params)
        filter_distance(p["t"], p["range"], smoothed.di_m, smoothed.var_m2, PARAMS)
    return time.perf_counter() - start


def run_calibrated(pairs: list[dict[str, np.ndarray]]) -> float:
    """Seconds for what ``coopproc run`` does per pair since issue 10: DI smoothing, the
    structure-function calibration, a probe run for the innovation spread, and the
    forward + backward distance filter with the range-step test."""
    params = DISmoothingParams()
    start = time.perf_counter()
    for p in pairs:
        var = di_variance(p["t"], 0.005, 0.005, "sqrt")
        smoothed = smooth_di(p["t"], p["di_dr"], p["di_cp"], var, params)
        noise = pair_noise(p["t"], p["range"], smoothed.di_m)
        r_i = np.fmax(smoothed.var_m2, noise.growth_m2ps)
        probe = replace(PARAMS, sigma_m=noise.white_sigma_m, gamma_sigma=1e9, suspect_epochs=0)
        spread = robust_sigma(
            filter_distance(p["t"], p["range"], smoothed.di_m, r_i, probe).residual_m
        )
        tuned = replace(PARAMS, sigma_m=noise.white_sigma_m, detect_sigma_m=spread)
        filter_distance_two_way(p["t"], p["range"], smoothed.di_m, r_i, tuned)
    return time.perf_counter() - start


def run_filterpy(p: dict[str, np.ndarray], n: int) -> float:
    """Seconds for the same two filters as filterpy KalmanFilter objects, epoch by epoch."""
    from filterpy.kalman import KalmanFilter

    smooth = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
    smooth.F = np.array([[0.0, 1.0], [0.0, 1.0]])  # I^- = u + s (eq. (4) with u_k)
    smooth.B = np.array([[1.0], [0.0]])
    smooth.H = np.array([[1.0, 0.0]])
    smooth.P = np.diag([1e-4, 1e-4])
    smooth.R = np.array([[1e-4]])
    dist = KalmanFilter(dim_x=2, dim_z=2)
    dist.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    dist.H = np.eye(2)
    dist.x = np.array([[p["range"][0]], [0.0]])
    dist.P = np.diag([0.0225, 1.0])
    gamma = 3.0 * 0.15
    start = time.perf_counter()
    for k in range(1, n):
        var = 2.0 * 0.005**2
        smooth.Q = np.array([[var, 0.0], [0.0, 1e-10]])
        smooth.predict(u=np.array([[p["di_dr"][k]]]))
        y = p["di_cp"][k] - smooth.x[0, 0]
        if abs(y) <= 3.0 * np.sqrt(smooth.P[0, 0] + smooth.R[0, 0]):
            smooth.update(np.array([[p["di_cp"][k]]]))
        dist.Q = 0.25 * np.ones((2, 2))
        dist.predict()
        dist.R = np.diag([0.0225, max(smooth.P[0, 0], 1e-8)])
        residual = p["range"][k] - dist.x[0, 0]  # eq. (9)
        if abs(residual) > gamma:  # NLOS: the DI observation only
            dist.update(np.array([[smooth.x[0, 0]]]), R=dist.R[1:, 1:], H=np.array([[0.0, 1.0]]))
        else:
            dist.update(np.array([[p["range"][k]], [smooth.x[0, 0]]]))
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=45)
    parser.add_argument("--epochs", type=int, default=86_400)
    parser.add_argument("--filterpy-epochs", type=int, default=20_000)
    parser.add_argument("--quick", action="store_true", help="epochs / 10")
    args = parser.parse_args()
    epochs = args.epochs // 10 if args.quick else args.epochs
    pairs = [make_pair(epochs, seed) for seed in range(args.pairs)]
    run_coopproc([make_pair(100, 0)])  # compile (numba, cache=True)
    run_calibrated([make_pair(100, 0)])
    seconds = min(run_coopproc(pairs) for _ in range(3))
    calibrated = min(run_calibrated(pairs) for _ in range(3))
    total = args.pairs * epochs
    ours = total / seconds
    n_fp = min(args.filterpy_epochs, epochs)
    fp_seconds = run_filterpy(pairs[0], n_fp)
    theirs = (n_fp - 1) / fp_seconds
    print(f"workload: {args.pairs} pairs x {epochs} epochs = {total:,} pair-epochs")
    print(f"{'method':<34}{'seconds':>10}{'pair-epochs/s':>18}")
    print(f"{'coopproc (numba, all pairs)':<34}{seconds:>10.3f}{ours:>18,.0f}")
    label = "  + calibration, two-way, step test"
    print(f"{label:<34}{calibrated:>10.3f}{total / calibrated:>18,.0f}")
    print(f"{'filterpy KalmanFilter (1 pair)':<34}{fp_seconds:>10.3f}{theirs:>18,.0f}")
    print(f"speed-up: {ours / theirs:,.0f}x  (targets: >= 2,000,000 pair-epochs/s, >= 50x)")


if __name__ == "__main__":
    main()
