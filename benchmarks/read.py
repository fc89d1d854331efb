"""Benchmark reading + validating a session: CSV directory and one MCAP file.

Default: 1 hour, 10 platforms: nav at 10 Hz (360,000 rows), ranges of all 45 pairs at
1 Hz (162,000 rows), a 1 Hz RTKLIB reference per platform (36,000 epochs). Written with
coopproc's writers into a temporary directory, then ``read_session`` is timed (best of
``--repeat``). Targets (issue 2): whole CSV session < 2 s; MCAP >= 200,000 messages/s.

    /work/venv/bin/python benchmarks/read.py [--hours 1] [--platforms 10] [--repeat 3]
        [--ros2]   # also time a ROS 2 (CDR) MCAP
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from coopproc.io import read_session, write_mcap, write_session
from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory, pair_name


def build(hours: float, n_platforms: int, seed: int = 0) -> Session:
    """A formation moving on a loop; nav 10 Hz with sigmas, ranges 1 Hz, 1 Hz reference."""
    rng = np.random.default_rng(seed)
    t0 = 432000.0
    t = t0 + np.arange(0.0, hours * 3600.0, 0.1)
    ids = [f"P{i:02d}" for i in range(n_platforms)]
    nav, ref, truth = {}, {}, {}
    for i, pid in enumerate(ids):
        phase = (t - t0) / 600.0 + 0.05 * i
        pos = np.column_stack(
            [300.0 * np.sin(phase) + 3 * i, 300.0 * (1 - np.cos(phase)), np.full(t.size, 0.1 * i)]
        )
        truth[pid] = pos
        nav[pid] = Trajectory(
            pid,
            t.copy(),
            pos + rng.normal(0, 0.3, pos.shape),
            sigma_enu_m=np.full(pos.shape, 0.3),
        )
        ref[pid] = Trajectory(
            pid,
            t[::10].copy(),
            pos[::10],
            sigma_enu_m=np.full((t[::10].size, 3), 0.01),
            quality=np.ones(t[::10].size, dtype=np.int64),
        )
    tr = t[::10]
    frames = []
    for a, b in itertools.combinations(ids, 2):
        d = np.linalg.norm(truth[a][::10] - truth[b][::10], axis=1)
        frames.append(
            pd.DataFrame(
                {
                    "time": tr,
                    "pair": pair_name(a, b),
                    "from": a,
                    "to": b,
                    "range": d + rng.normal(0, 0.1, d.size),
                    "sigma": 0.1,
                    "rssi": np.round(rng.normal(-80, 3, d.size), 1),
                }
            )
        )
    ranges = pd.concat(frames).sort_values("time", kind="stable").reset_index(drop=True)
    platforms = {p: Platform(p, "leader" if i == 0 else "follower") for i, p in enumerate(ids)}
    config = SessionConfig(
        name="bench", gps_week=2178, origin_llh=(34.798, 113.659, 110.0), platforms=platforms
    )
    return Session(
        config=config,
        platforms=platforms,
        nav=nav,
        reference=ref,
        ranges=RangeTable(ranges),
        origin_llh=config.origin_llh or (0.0, 0.0, 0.0),
        root=Path("."),
    )


def best_of(repeat: int, fn: Callable[[], object]) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--ros2", action="store_true", help="also time a ROS 2 MCAP")
    args = parser.parse_args()
    session = build(args.hours, args.platforms)
    n_nav = sum(len(t) for t in session.nav.values())
    n_ref = sum(len(t) for t in session.reference.values())
    n_rng = len(session.ranges)
    total = n_nav + n_ref + n_rng
    print(f"session: {n_nav:,} nav rows, {n_rng:,} ranges, {n_ref:,} reference epochs")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        start = time.perf_counter()
        write_session(session, root / "csv")
        print(f"write CSV session:  {time.perf_counter() - start:6.2f} s")
        start = time.perf_counter()
        write_mcap(session, root / "s.mcap")
        print(f"write MCAP (JSON):  {time.perf_counter() - start:6.2f} s")
        t_csv = best_of(args.repeat, lambda: read_session(root / "csv"))
        print(
            f"read CSV session:   {t_csv:6.2f} s  {total / t_csv:12,.0f} rows/s "
            f"(target < 2 s: {'ok' if t_csv < 2 else 'MISSED'})"
        )
        t_mcap = best_of(args.repeat, lambda: read_session(root / "s.mcap"))
        print(
            f"read MCAP (JSON):   {t_mcap:6.2f} s  {total / t_mcap:12,.0f} messages/s "
            f"(target >= 200,000: {'ok' if total / t_mcap >= 200_000 else 'MISSED'})"
        )
        if args.ros2:
            start = time.perf_counter()
            write_mcap(session, root / "r.mcap", encoding="ros2")
            print(f"write MCAP (ROS 2): {time.perf_counter() - start:6.2f} s")
            t_ros = best_of(1, lambda: read_session(root / "r.mcap"))
            print(f"read MCAP (ROS 2):  {t_ros:6.2f} s  {total / t_ros:12,.0f} messages/s")


if __name__ == "__main__":
    main()
