"""Benchmark the CLI start: ``coopproc --version``, ``--help`` and ``run --help``.

Each is run as a new process (``python -m coopproc``) ``--repeat`` times; the best and the
median wall-clock seconds are printed. Target (issue 16): 0.5 s or less for each. Where
the time goes: ``python -X importtime -m coopproc --version``.

    /work/venv/bin/python benchmarks/cli_start.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

COMMANDS = (["--version"], ["--help"], ["run", "--help"])


def seconds(args: list[str], repeat: int) -> list[float]:
    """Wall-clock seconds of ``repeat`` runs of ``python -m coopproc ARGS``."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "coopproc", *args], check=True, stdout=subprocess.DEVNULL
        )
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    for command in COMMANDS:
        times = seconds(command, args.repeat)
        print(
            f"coopproc {' '.join(command):<12} best {min(times):.3f} s, "
            f"median {statistics.median(times):.3f} s"
        )


if __name__ == "__main__":
    main()
