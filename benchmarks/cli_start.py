"""Benchmark the CLI start: ``coopproc --version``, ``--help`` and ``run --help``.

Each is run as a new process (``python -m coopproc``) ``--repeat`` times after one
warm-up run (files in the page cache); the median and the best wall-clock seconds are
printed, with the load average (the machine is shared). Target (issue 16): a median of
0.5 s or less for each. Where the time goes: ``python -X importtime -m coopproc --version``.

    /work/venv/bin/python benchmarks/cli_start.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

from _common import target

COMMANDS = (["--version"], ["--help"], ["run", "--help"])


def seconds(args: list[str], repeat: int) -> list[float]:
    """Wall-clock seconds of ``repeat`` runs of ``python -m coopproc ARGS``."""
    times = []
    subprocess.run(
        [sys.executable, "-P", "-m", "coopproc", *args], check=True, stdout=subprocess.DEVNULL
    )
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-P", "-m", "coopproc", *args], check=True, stdout=subprocess.DEVNULL
        )
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    medians = {}
    for command in COMMANDS:
        times = seconds(command, args.repeat)
        name = " ".join(command)
        medians[name] = statistics.median(times)
        print(
            f"coopproc {name:<12} median {medians[name]:.3f} s, best {min(times):.3f} s "
            f"(load {os.getloadavg()[0]:.2f})"
        )
    for name, median in medians.items():
        print(target(f"coopproc {name} <= 0.5 s", median, 0.5, at_most=True))


if __name__ == "__main__":
    main()
