"""Benchmark a campaign: `coopproc batch` over many sessions on the local Dask cluster.

Simulates one `large` session (10 platforms, --hours long) into a cache directory and lays
out --sessions copies of it under distinct names (hard links: the same work each, no disk
cost; --distinct simulates a new seed for each), then runs the real CLI

    coopproc batch SESSIONS... -o OUT --workers J [--worker-memory SIZE] [--no-figures]

as a subprocess, sampling the resident memory of every process of the batch (the client,
which also runs the local cluster's scheduler, and each worker, with psutil) twice a
second. Prints the load average before and after (the machine may be shared), wall time,
sessions per minute, the largest worker RSS against the per-worker memory limit
(`--worker-memory`, default the machine's memory divided by the workers) and the total,
and one line per target.

    python benchmarks/campaign.py [--sessions 50] [--hours 1] [--workers 2] [--no-figures]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

from coopproc.run.batch_memory import TERMINATE_FRACTION, worker_memory_limit
from coopproc.sim import simulate, write_simulation

#: A worker's peak resident memory should stay below this (GB): one session at a time.
WORKER_TARGET_GB = 2.0


def _session(cache: Path, hours: float, seed: int) -> Path:
    path = cache / f"large_10p_{hours:g}h_seed{seed}"
    if not (path / "session.toml").exists():
        sim = simulate("large", seed=seed, duration_s=hours * 3600.0, platforms=10)
        tmp = path.with_name(path.name + ".tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        write_simulation(sim, tmp)
        tmp.rename(path)
    return path


def _link_copy(src: Path, dst: Path) -> None:
    shutil.copytree(src, dst, copy_function=os.link)


class _Sampler(threading.Thread):
    """Peak RSS of the batch process tree: the client (the `coopproc batch` process, which
    runs the local scheduler and pools the sessions' errors at the end), the largest child
    (a worker: the other children, multiprocessing's resource tracker, are small) and the
    sum."""

    def __init__(self, pid: int) -> None:
        super().__init__(daemon=True)
        self.root = psutil.Process(pid)
        self.peak_client = 0
        self.peak_one = 0
        self.peak_sum = 0
        self.peak_load = 0.0
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            try:
                client = self.root.memory_info().rss
                sizes = []
                for proc in self.root.children(recursive=True):
                    try:
                        sizes.append(proc.memory_info().rss)
                    except psutil.Error:
                        continue
                self.peak_client = max(self.peak_client, client)
                self.peak_one = max(self.peak_one, max(sizes, default=0))
                self.peak_sum = max(self.peak_sum, client + sum(sizes))
                self.peak_load = max(self.peak_load, os.getloadavg()[0])
            except psutil.Error:
                pass
            self.stop.wait(0.5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=50)
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--worker-memory", help="SIZE per worker (default: coopproc's)")
    parser.add_argument("--no-figures", action="store_true")
    parser.add_argument("--distinct", action="store_true", help="a new seed per session")
    parser.add_argument(
        "--cache", type=Path, default=Path(tempfile.gettempdir()) / "coopproc-bench-cache"
    )
    args = parser.parse_args()
    limit, _ = worker_memory_limit(args.worker_memory, args.workers)
    load_before = os.getloadavg()
    args.cache.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        sessions = []
        for k in range(args.sessions):
            src = _session(args.cache, args.hours, k if args.distinct else 0)
            dst = root / "sessions" / f"s{k:03d}"
            _link_copy(src, dst)
            sessions.append(str(dst))
        t_prep = time.perf_counter() - t0
        cmd = [
            sys.executable, "-m", "coopproc", "batch", *sessions, "-o", str(root / "out"),
            "--workers", str(args.workers), "--quiet",
        ]  # fmt: skip
        if args.no_figures:
            cmd.append("--no-figures")
        if args.worker_memory:
            cmd += ["--worker-memory", args.worker_memory]
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd)
        sampler = _Sampler(proc.pid)
        sampler.start()
        code = proc.wait()
        wall = time.perf_counter() - t0
        sampler.stop.set()
        sampler.join()
        done = sum(1 for s in sessions if (root / "out" / Path(s).name / "run.json").exists())
    gb = 1e9
    per_min = done / wall * 60.0
    print(
        f"campaign: {args.sessions} x large 10 platforms {args.hours:g} h, "
        f"{args.workers} workers, figures {'off' if args.no_figures else 'on'}; "
        f"{os.cpu_count()} CPUs"
    )
    loads = ", ".join(f"{a:.2f}/{b:.2f}" for a, b in zip(load_before, os.getloadavg(), strict=True))
    print(f"load average 1/5/15 min, before/after: {loads} (other jobs count too)")
    print(f"load average 1 min, highest during the batch: {sampler.peak_load:.2f}")
    print(f"prepare sessions     {t_prep:8.1f} s")
    print(f"coopproc batch       {wall:8.1f} s  (exit {code}, {done}/{args.sessions} complete)")
    print(f"sessions per minute  {per_min:8.2f}")
    print(
        f"largest worker RSS   {sampler.peak_one / gb:8.2f} GB of a {limit / gb:.2f} GB limit "
        f"per worker ({sampler.peak_one / limit:.0%}; restarted above {TERMINATE_FRACTION:.0%})"
    )
    print(f"client RSS           {sampler.peak_client / gb:8.2f} GB (pools every session's errors)")
    print(f"all processes RSS    {sampler.peak_sum / gb:8.2f} GB (peak of the sum)")
    ok = code == 0 and done == args.sessions
    print(f"target: every session completes: {'met' if ok else 'missed'} ({done}/{args.sessions})")
    ratio = sampler.peak_one / gb / WORKER_TARGET_GB
    verdict = "met" if ratio <= 1.0 else "missed"
    print(f"target: worker RSS <= {WORKER_TARGET_GB:g} GB: {verdict} (ratio {ratio:.2f})")
    ratio = sampler.peak_one / (TERMINATE_FRACTION * limit)
    verdict = "met" if ratio <= 1.0 else "missed"
    print(
        f"target: worker RSS below its restart point ({TERMINATE_FRACTION:.0%} of "
        f"{limit / gb:.2f} GB): {verdict} (ratio {ratio:.2f})"
    )


if __name__ == "__main__":
    main()
