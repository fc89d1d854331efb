"""Benchmark the whole `coopproc run` chain on the simulator's `large` scenario.

Simulates N platforms for H hours (nav 10 Hz, ranges 1 Hz for every pair, NLOS events),
writes the session with the real writers, then times reading, the pipeline (fusion x 3,
DI/RN ranging, metrics) and writing the tables, and prints range epochs per second.

    python benchmarks/pipeline.py [--hours 1] [--platforms 10]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import tempfile
import time
from pathlib import Path

from coopproc.io import read_session
from coopproc.run.config import RunConfig
from coopproc.run.output import write_run
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate, write_simulation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--platforms", type=int, default=10)
    args = parser.parse_args()

    t0 = time.perf_counter()
    sim = simulate("large", seed=0, duration_s=args.hours * 3600.0, platforms=args.platforms)
    t_sim = time.perf_counter() - t0
    config = RunConfig()
    config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
    with tempfile.TemporaryDirectory() as tmp:
        session_dir = Path(tmp) / "session"
        t0 = time.perf_counter()
        write_simulation(sim, session_dir)
        t_write_in = time.perf_counter() - t0

        t0 = time.perf_counter()
        session = read_session(session_dir)
        t_read = time.perf_counter() - t0

        t0 = time.perf_counter()
        output = run_pipeline(session, config)
        t_pipe = time.perf_counter() - t0

        t0 = time.perf_counter()
        write_run(output, session, config, Path(tmp) / "out", started=dt.datetime.now(dt.UTC))
        t_write = time.perf_counter() - t0

    n_ranges = len(session.ranges)
    n_pairs = len(session.ranges.pairs)
    print(
        f"large: {args.platforms} platforms, {args.hours:g} h, {n_pairs} pairs, {n_ranges:,} ranges"
    )
    print(f"simulate (in memory)   {t_sim:7.2f} s")
    print(f"write session files    {t_write_in:7.2f} s")
    print(f"read + validate        {t_read:7.2f} s")
    print(f"pipeline               {t_pipe:7.2f} s   {n_ranges / t_pipe:,.0f} ranges/s")
    for label, seconds in output.timings_s.items():
        print(f"  {label:<22} {seconds:7.2f} s")
    print(f"write tables           {t_write:7.2f} s")
    total = t_read + t_pipe + t_write
    print(f"coopproc run total     {total:7.2f} s (read + pipeline + tables, no figures)")


if __name__ == "__main__":
    main()
