"""Benchmark reading a session as ``coopproc run`` does: CSV directory and MCAP file.

The session is what ``coopproc simulate --scenario large --mcap`` writes (seed 0): nav at
10 Hz per platform, every pair ranging at 1 Hz with staggered polling (a distinct time
per pair), an RTKLIB reference at 5 Hz per platform, and the same data as one MCAP file
(JSON channels; ``--ros2``: also ROS 2 CDR). Timed, each the median of ``--repeat`` runs
after a warm-up (files in the page cache):

- ``read_session`` (read and validate) of the directory and of the MCAP file;
- ``prepare_run``: what ``coopproc run`` does next (coverage, frame checks);
- the peer: a plain ``pandas.read_csv`` of the same files (ranges.csv, nav_*.csv, and the
  .pos files as whitespace-separated text), parsing only, no validation or conversion.

Targets (issue 2): the CSV session of 10 platforms x 1 h read in < 2 s; MCAP >= 200,000
messages/s.

    python benchmarks/read.py                      # 10 platforms x 1 h
    python benchmarks/read.py --hours 4 --ros2 --cache ~/.cache/coopproc-bench
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from _common import count_lines, load, median_seconds, session_dir, spread, target

from coopproc.checks.coverage import prepare_run
from coopproc.io import read_session


def plain_pandas(root: Path) -> None:
    """Parse every table file of the session with pandas alone."""
    pd.read_csv(root / "ranges.csv")
    for path in sorted(root.glob("nav_*.csv")):
        pd.read_csv(path)
    for path in sorted(root.glob("ref_*.pos")):
        pd.read_csv(path, sep=r"\s+", comment="%", header=None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cache", type=Path, help="keep the simulated sessions here")
    parser.add_argument("--ros2", action="store_true", help="also time a ROS 2 (CDR) MCAP")
    args = parser.parse_args()

    root = session_dir(args.hours, args.platforms, args.cache, mcap="json")
    n_rng = count_lines(root / "ranges.csv") - 1
    n_nav = sum(count_lines(p) - 1 for p in root.glob("nav_*.csv"))
    n_ref = sum(
        sum(1 for line in p.open() if not line.startswith("%")) for p in root.glob("ref_*.pos")
    )
    total = n_nav + n_ref + n_rng
    print(
        f"large: {args.platforms} platforms x {args.hours:g} h: {n_nav:,} nav rows, "
        f"{n_rng:,} ranges, {n_ref:,} reference epochs ({load()})"
    )

    t_csv, times = median_seconds(lambda: read_session(root), args.repeat)
    print(f"read CSV session:   {t_csv:6.2f} s {total / t_csv:12,.0f} rows/s  ({spread(times)})")
    session = read_session(root)
    t_prep, times = median_seconds(lambda: prepare_run(session), args.repeat)
    print(f"prepare_run:        {t_prep:6.2f} s  ({spread(times)})")
    t_pd, times = median_seconds(lambda: plain_pandas(root), args.repeat)
    print(
        f"plain pandas:       {t_pd:6.2f} s {total / t_pd:12,.0f} rows/s  ({spread(times)}); "
        f"read_session takes {t_csv / t_pd:.1f}x"
    )
    mcap = root / "mcap" / "large.mcap"
    t_mcap, times = median_seconds(lambda: read_session(mcap), args.repeat)
    print(
        f"read MCAP (JSON):   {t_mcap:6.2f} s {total / t_mcap:12,.0f} messages/s  "
        f"({spread(times)}; {load()})"
    )
    if args.ros2:
        ros = session_dir(args.hours, args.platforms, args.cache, mcap="ros2")
        t_ros, times = median_seconds(lambda: read_session(ros / "mcap" / "large.mcap"), 1)
        print(f"read MCAP (ROS 2):  {t_ros:6.2f} s {total / t_ros:12,.0f} messages/s")
    name = f"{args.platforms} x {args.hours:g} h"
    print(target(f"read CSV session ({name}) < 2 s", t_csv, 2.0, at_most=True))
    print(target("read MCAP >= 200,000 messages/s", total / t_mcap, 200_000, at_most=False))


if __name__ == "__main__":
    main()
