"""Shared pieces of the benchmarks: the simulator's session shapes, repeated timing and
target lines (imported by the scripts in this directory, which Python puts on sys.path).

- sessions come from the simulator's ``large`` scenario (seed 0 unless a benchmark picks
  another, as ``scale.py --workload dense`` does: nav 10 Hz, every pair
  ranging at 1 Hz with staggered polling, i.e. a distinct time per pair, 5 Hz reference)
  written by ``write_simulation``, exactly as ``coopproc simulate --scenario large``
  writes them; ``--cache DIR`` keeps them between runs;
- every figure is the median of ``repeat`` runs after one warm-up run (numba compiled
  or loaded from its cache, files in the page cache), peers included;
- one line per target: ``target <what>: met|missed (ratio x.xx)``, ratio = measured /
  target (met when <= 1 for an upper bound, >= 1 for a lower bound), or ``not
  comparable: <reason>`` when the run did not do the work (``_work.verdict``);
- the 1-minute load average is printed with each figure: the machine is shared.
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
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
    seed: int = 0,
    **overrides: Any,
) -> Path:
    """The ``large`` session of ``platforms`` x ``hours`` (``seed``) as files on disk.

    Simulated and written once per cache directory (``cache`` None: a temporary one
    removed at exit); a cached session is reused as is (delete the cache when the
    simulator changes). ``mcap`` ("json" or "ros2"): also the MCAP file the simulator
    writes, ``mcap/large.mcap``. ``overrides``: further SimParams fields of the scenario.
    """
    root = cache if cache is not None else _temp_root()
    extra = "".join(f"_{k}{v}" for k, v in sorted(overrides.items()))
    extra += f"_mcap{mcap}" if mcap else ""
    path = root / f"large_p{platforms}_h{hours:g}_s{seed}{extra}"
    if not (path / "session.toml").is_file():
        from coopproc.sim import simulate, write_simulation

        root.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        sim = simulate(
            "large", seed=seed, duration_s=hours * 3600.0, platforms=platforms, **overrides
        )
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


def target(
    what: str, measured: float, limit: float, *, at_most: bool, incomplete: str | None = None
) -> str:
    """``target <what>: met|missed (ratio x.xx)``; ratio = measured / limit.

    ``incomplete``: why the run behind ``measured`` did not do the work the target is
    about (``_work.verdict``): then ``not comparable: <reason>`` instead of met/missed,
    with the ratio still shown."""
    ratio = measured / limit if limit else float("inf")
    met = ratio <= 1.0 if at_most else ratio >= 1.0
    shown = f"{ratio:.2f}" if ratio >= 0.1 else f"{ratio:.2g}"
    if incomplete:
        return f"target {what}: not comparable: {incomplete} (ratio {shown})"
    return f"target {what}: {'met' if met else 'missed'} (ratio {shown})"


@dataclass(frozen=True)
class CliRun:
    """One ``coopproc`` child process."""

    seconds: float
    peak_rss_bytes: int
    returncode: int
    stderr: str
    #: the largest sum of PSS over the child and its own children (forked page or
    #: fusion workers), sampled every :data:`TREE_SAMPLE_S`; 0 where /proc has no
    #: smaps_rollup (not Linux)
    peak_tree_bytes: int = 0
    #: per phase of the run (its "run: <phase> done in" lines, in order), the largest
    #: PSS sum sampled while it ran (from the previous phase's line to its own; the
    #: first phase from the fork: imports and start-up are in it); empty without samples
    phase_peak_bytes: dict[str, int] = field(default_factory=dict)

    @property
    def peak_bytes(self) -> int:
        """The memory figure the targets use: the larger of the child's own peak RSS
        and the process tree's peak PSS (pages shared copy-on-write by forked workers
        counted once, split between them)."""
        return max(self.peak_rss_bytes, self.peak_tree_bytes)


#: Seconds between two samples of the process tree's memory.
TREE_SAMPLE_S = 0.2


def _pss_bytes(pid: int) -> int:
    """Proportional set size of one process (its share of pages it shares), 0 if gone."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as handle:
            for line in handle:
                if line.startswith("Pss:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return 0
    return 0


def _descendants(pid: int) -> list[int]:
    """pid and every process below it (from /proc/*/task/*/children)."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as handle:
                    todo += [int(c) for c in handle.read().split()]
        except OSError:
            continue
    return out


class _TreeSampler:
    """Samples the PSS sum of a process tree in a thread until stopped."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.peak = 0
        #: (perf_counter, PSS sum) of every sample
        self.samples: list[tuple[float, int]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            pss = sum(_pss_bytes(p) for p in _descendants(self.pid))
            self.samples.append((time.perf_counter(), pss))
            self.peak = max(self.peak, pss)
            self._stop.wait(TREE_SAMPLE_S)

    def stop(self) -> int:
        self._stop.set()
        self._thread.join()
        return self.peak


def run_cli(args: Sequence[str], env: dict[str, str] | None = None) -> CliRun:
    """Run ``python -P -m coopproc ARGS`` as a new process: this interpreter, and with
    ``-P`` the working directory is not put first on sys.path, so PYTHONPATH or the
    installed package chooses the code. Wall seconds from before the fork to its exit,
    peak RSS of that child alone (``os.wait4`` gives its own rusage; ru_maxrss is in KiB
    on Linux; for waited-for grandchildren the largest of them, never their sum) and the
    peak PSS sum over the child and its children (:class:`_TreeSampler`: a forked worker
    shares the parent's pages, so the RSS sum would count them twice)."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-P", "-m", "coopproc", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    assert proc.stderr is not None
    sampler = _TreeSampler(proc.pid) if os.path.exists("/proc/self/smaps_rollup") else None
    lines, ends = [], []
    for line in proc.stderr:  # until the child closes it (it exits); stderr is line-buffered
        lines.append(line)
        done = _PHASE_DONE.match(line)
        if done:
            ends.append((done.group(1), time.perf_counter()))
    tree = sampler.stop() if sampler is not None else 0
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    phases = _phase_peaks(sampler.samples, start, ends) if sampler is not None else {}
    return CliRun(
        seconds, int(usage.ru_maxrss) * 1024, proc.returncode, "".join(lines), tree, phases
    )


#: A phase's progress line on stderr (coopproc.run.progress): ``run: <phase> done in``.
_PHASE_DONE = re.compile(r"^run: (.+?) done in ")


def _phase_peaks(
    samples: Sequence[tuple[float, int]], start: float, ends: Sequence[tuple[str, float]]
) -> dict[str, int]:
    """Per phase (``ends``: its label and when its line arrived), the largest sample
    taken since the line before (the first: since ``start``); a phase without a sample
    in its span (shorter than the sampling interval) gets the sample nearest its end."""
    out: dict[str, int] = {}
    begin = start
    for label, end in ends:
        inside = [pss for t, pss in samples if begin < t <= end]
        if not inside and samples:
            inside = [min(samples, key=lambda s: abs(s[0] - end))[1]]
        if inside:
            out[label] = max(out.get(label, 0), max(inside))
        begin = end
    return out


def count_lines(path: Path) -> int:
    """Newlines in a file (a CSV's rows + 1 header)."""
    total = 0
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 22), b""):
            total += block.count(b"\n")
    return total
