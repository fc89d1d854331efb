"""Shared pieces of the benchmarks: the simulator's session shapes, repeated timing and
target lines (imported by the scripts in this directory, which Python puts on sys.path).

- sessions come from the simulator's ``large`` scenario (seed 0: nav 10 Hz, every pair
  ranging at 1 Hz with staggered polling, i.e. a distinct time per pair, 5 Hz reference)
  written by ``write_simulation``, exactly as ``coopproc simulate --scenario large``
  writes them; ``--cache DIR`` keeps them between runs;
- every figure is the median of ``repeat`` runs after one warm-up run (numba compiled
  or loaded from its cache, files in the page cache), peers included;
- one line per target: ``target <what>: met|missed (ratio x.xx)``, ratio = measured /
  target (met when <= 1 for an upper bound, >= 1 for a lower bound);
- the 1-minute load average is printed with each figure: the machine is shared.
"""

from __future__ import annotations

import atexit
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "CliRun",
    "count_lines",
    "load",
    "median_seconds",
    "run_cli",
    "session_dir",
    "spread",
    "target",
]

_TEMP: list[Path] = []


def load() -> str:
    """The load averages, for the line next to a measurement."""
    one, five, fifteen = os.getloadavg()
    return f"load {one:.2f} {five:.2f} {fifteen:.2f}"


def _temp_root() -> Path:
    if not _TEMP:
        path = Path(tempfile.mkdtemp(prefix="coopproc-bench-"))
        _TEMP.append(path)
        atexit.register(shutil.rmtree, path, True)
    return _TEMP[0]


def session_dir(
    hours: float,
    platforms: int,
    cache: Path | None = None,
    mcap: str | None = None,
    **overrides: Any,
) -> Path:
    """The ``large`` session of ``platforms`` x ``hours`` (seed 0) as files on disk.

    Simulated and written once per cache directory (``cache`` None: a temporary one
    removed at exit); a cached session is reused as is (delete the cache when the
    simulator changes). ``mcap`` ("json" or "ros2"): also the MCAP file the simulator
    writes, ``mcap/large.mcap``. ``overrides``: further SimParams fields of the scenario.
    """
    root = cache if cache is not None else _temp_root()
    extra = "".join(f"_{k}{v}" for k, v in sorted(overrides.items()))
    extra += f"_mcap{mcap}" if mcap else ""
    path = root / f"large_p{platforms}_h{hours:g}_s0{extra}"
    if not (path / "session.toml").is_file():
        from coopproc.sim import simulate, write_simulation

        root.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        sim = simulate("large", seed=0, duration_s=hours * 3600.0, platforms=platforms, **overrides)
        if mcap:
            write_simulation(sim, path, force=True, mcap=True, mcap_encoding=mcap)  # type: ignore[arg-type]
        else:
            write_simulation(sim, path, force=True)
        print(
            f"(simulated {path.name}: {time.perf_counter() - start:.1f} s)",
            file=sys.stderr,
        )
    return path


def median_seconds(
    fn: Callable[[], object], repeat: int = 3, warmup: int = 1
) -> tuple[float, list[float]]:
    """Median wall seconds of ``repeat`` calls after ``warmup`` untimed ones, and all."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(max(repeat, 1)):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times


def spread(times: Sequence[float]) -> str:
    """``min-max`` of repeated runs, for the line beside a median."""
    return f"{min(times):.3f}-{max(times):.3f} s over {len(times)}"


def target(what: str, measured: float, limit: float, *, at_most: bool) -> str:
    """``target <what>: met|missed (ratio x.xx)``; ratio = measured / limit."""
    ratio = measured / limit if limit else float("inf")
    met = ratio <= 1.0 if at_most else ratio >= 1.0
    shown = f"{ratio:.2f}" if ratio >= 0.1 else f"{ratio:.2g}"
    return f"target {what}: {'met' if met else 'missed'} (ratio {shown})"


@dataclass(frozen=True)
class CliRun:
    """One ``coopproc`` child process."""

    seconds: float
    peak_rss_bytes: int
    returncode: int
    stderr: str


def run_cli(args: Sequence[str], env: dict[str, str] | None = None) -> CliRun:
    """Run ``python -P -m coopproc ARGS`` as a new process: this interpreter, and with
    ``-P`` the working directory is not put first on sys.path, so PYTHONPATH or the
    installed package chooses the code. Wall seconds from before the fork to its exit,
    peak RSS of that child alone (``os.wait4`` gives its own rusage; ru_maxrss is in KiB
    on Linux)."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-P", "-m", "coopproc", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    assert proc.stderr is not None
    err = proc.stderr.read()  # until the child closes it (it exits)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    return CliRun(seconds, int(usage.ru_maxrss) * 1024, proc.returncode, err)


def count_lines(path: Path) -> int:
    """Newlines in a file (a CSV's rows + 1 header)."""
    total = 0
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 22), b""):
            total += block.count(b"\n")
    return total
