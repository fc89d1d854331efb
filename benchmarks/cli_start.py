"""Benchmark the CLI start (``coopproc --version``, ``--help``, ``run --help``) and the
first and later runs of ``coopproc run sample_logs``.

Each start command is run as a new process (``python -m coopproc``) ``--repeat`` times
after one warm-up run (files in the page cache); the median and the best wall-clock
seconds are printed, with the load average (the machine is shared). Target (issue 16):
a median of 0.5 s or less for each. Where the time goes: ``python -X importtime -m
coopproc --version``.

Then (issue 32) ``coopproc run sample_logs`` (figures included) once with an empty
numba cache (NUMBA_CACHE_DIR pointed at a new temporary directory: every kernel is
compiled, as on the first run after an install) and ``--repeat`` times with that cache
warm: wall-clock and CPU seconds (the children's user + system time: what the load of
the shared machine does not stretch) and the load average. Targets: first run <= 30 s,
later runs <= 8 s (wall-clock, 2-core machine). ``--no-run`` skips them. The runs write
Python's bytecode cache (``PYTHONDONTWRITEBYTECODE`` is dropped from their environment):
an installed package has it (pip compiles the modules on install, an editable install on
its first import), and without it every run compiles the ~300 modules' source again
(1.1 s CPU on this machine, whose environment sets it). On a cold run with two CPUs a
second process compiles the later kernels meanwhile (coopproc/jit_ahead.py): its CPU
time is in the CPU seconds printed.

    /work/venv/bin/python benchmarks/cli_start.py [--repeat 5] [--no-run]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import target

COMMANDS = (["--version"], ["--help"], ["run", "--help"])

SAMPLE = Path(__file__).resolve().parents[1] / "sample_logs"


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


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_seconds(cache_dir: str, out_dir: str) -> tuple[float, float]:
    """Wall-clock and CPU seconds of one ``coopproc run sample_logs`` with numba's cache
    in ``cache_dir``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as installed (module docstring)
    command = [sys.executable, "-P", "-m", "coopproc", "run", str(SAMPLE), "-o", out_dir]
    cpu = _children_cpu()
    start = time.perf_counter()
    subprocess.run([*command, "--force", "-q"], check=True, env=env)
    return time.perf_counter() - start, _children_cpu() - cpu


def first_and_later_runs(repeat: int) -> None:
    """The first run (empty numba cache) and ``repeat`` later ones, with targets."""
    with tempfile.TemporaryDirectory(prefix="coopproc-bench-") as tmp:
        cache, out = os.path.join(tmp, "numba"), os.path.join(tmp, "out")
        os.mkdir(cache)
        wall, cpu = run_seconds(cache, out)
        print(
            f"coopproc run sample_logs, first (empty numba cache): {wall:.1f} s, "
            f"CPU {cpu:.1f} s (load {os.getloadavg()[0]:.2f})"
        )
        later = [run_seconds(cache, out) for _ in range(repeat)]
        walls = [w for w, _ in later]
        print(
            f"coopproc run sample_logs, later (cache warm): median "
            f"{statistics.median(walls):.1f} s, best {min(walls):.1f} s, "
            f"CPU {statistics.median(c for _, c in later):.1f} s "
            f"(load {os.getloadavg()[0]:.2f})"
        )
    print(target("first coopproc run sample_logs <= 30 s", wall, 30.0, at_most=True))
    print(
        target("later coopproc run sample_logs <= 8 s", statistics.median(walls), 8.0, at_most=True)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--no-run", action="store_true", help="Only the start commands.")
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
    if not args.no_run:
        first_and_later_runs(args.repeat)


if __name__ == "__main__":
    main()
