"""Benchmark the cooperative EKF and RTS smoother: N platforms, H hours at 1 Hz.

Default: 10 platforms (1 leader, 9 followers), 24 h at 1 Hz = 86,400 epochs with all
45 pair ranges each, state 2 x 10. Prints epochs/s of the forward filter and of the RTS
smoother (compiled kernels alone, and ``fuse`` end to end including data preparation).

    /work/venv/bin/python benchmarks/fusion.py [--hours 24] [--platforms 10] [--dims 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

import coopproc.stages.fusion.fuse as fusion_mod
from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory


def build(hours: float, n_platforms: int, seed: int = 0) -> tuple[Session, pd.DataFrame]:
    """A formation on a large loop; nav and ranges at 1 Hz, vectorized."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600.0, 1.0)
    radius = 500.0
    omega = 0.5 / radius
    ids = [f"P{i:02d}" for i in range(n_platforms)]
    truth = {}
    nav = {}
    platforms = {}
    for i, pid in enumerate(ids):
        r = radius + 6.0 * (i % 5) + 0.5 * np.sin(t / (70 + i))
        phase = omega * t - 0.02 * (i // 5)
        pos = np.stack([r * np.sin(phase), r * (1 - np.cos(phase)), np.zeros_like(t)], 1)
        truth[pid] = pos
        role: Literal["leader", "follower"] = "leader" if i == 0 else "follower"
        noise = 0.02 if i == 0 else 0.0
        err = rng.normal(0, noise, pos.shape)
        if i > 0:
            err = err + np.cumsum(rng.normal(0, 0.01, pos.shape), axis=0)
        nav[pid] = Trajectory(pid, t, pos + err)
        platforms[pid] = Platform(pid, role=role, drift_sigma_mps=0.02)
    frames = []
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            dist = np.linalg.norm(truth[a] - truth[b], axis=1)
            frames.append(
                pd.DataFrame(
                    {
                        "time": t,
                        "from": a,
                        "to": b,
                        "range": dist + rng.normal(0, 0.08, t.size),
                        "sigma": 0.15,
                    }
                )
            )
    ranges = pd.concat(frames).sort_values("time", kind="stable").reset_index(drop=True)
    session = Session(
        config=SessionConfig(platforms=platforms),
        platforms=platforms,
        nav=nav,
        reference={},
        ranges=RangeTable(ranges),
        origin_llh=(0.0, 0.0, 0.0),
        root=Path("bench"),
    )
    return session, ranges


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--dims", type=int, default=2)
    args = parser.parse_args()
    session, ranges = build(args.hours, args.platforms)
    timings: dict[str, float] = {}

    def timed(name: str, func: Any) -> Any:
        def wrapper(*a: Any, **k: Any) -> Any:
            start = time.perf_counter()
            result = func(*a, **k)
            timings[name] = time.perf_counter() - start
            return result

        return wrapper

    fusion_mod.ekf_forward = timed("forward", fusion_mod.ekf_forward)  # type: ignore[assignment]
    fusion_mod.rts_backward = timed("rts", fusion_mod.rts_backward)  # type: ignore[assignment]
    # warm-up (compile or load the numba cache) on a short slice
    short = ranges[ranges["time"] < 60.0]
    fusion_mod.fuse(session, short, fusion_mod.FusionParams(dims=args.dims))
    n_epochs = int(ranges["time"].nunique())
    print(
        f"{args.platforms} platforms, {n_epochs} epochs, {len(ranges)} ranges "
        f"({len(ranges) / n_epochs:.0f} per epoch), dims {args.dims}"
    )
    for smoother in (False, True):
        params = fusion_mod.FusionParams(dims=args.dims, smoother=smoother)
        start = time.perf_counter()
        fusion_mod.fuse(session, ranges, params)
        total = time.perf_counter() - start
        label = "forward + RTS" if smoother else "forward only"
        print(f"fuse() {label:14s}: {total:7.2f} s  {n_epochs / total:10.0f} epochs/s end to end")
        print(
            f"  forward kernel  : {timings['forward']:7.2f} s  "
            f"{n_epochs / timings['forward']:10.0f} epochs/s"
        )
        if smoother:
            rate = n_epochs / timings["rts"]
            print(f"  RTS kernel      : {timings['rts']:7.2f} s  {rate:10.0f} epochs/s")


if __name__ == "__main__":
    main()
