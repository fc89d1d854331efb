"""Benchmark the whole ``coopproc run`` on the simulator's ``large`` scenario.

The session is what ``coopproc simulate --scenario large`` writes (seed 0: nav 10 Hz,
every pair ranging at 1 Hz with staggered polling, 5 Hz reference). Two measurements:

- in process (``--mode in-process``): the steps ``coopproc run`` takes, each timed:
  reading, ``prepare_run``, the stage chain (run.json ``timings_s``: fusion x 3, ranging,
  metrics), the summary, and writing the tables, figures and HTML (``write_run``), after
  a warm-up run of the chain on a small session (numba compiled or loaded);
- the real CLI (``--mode cli``): ``python -m coopproc run SESSION -o OUT --force`` as a new
  process, after one warm-up process on a small session: wall time from the fork to the
  exit (process start, imports, numba cache loads and everything above) and the child's
  peak RSS; run.json's own ``duration_s`` and timings beside it.

Figures are on, as a user runs it (``--no-figures`` to leave them out). Targets (issue 11),
for 10 or 20 platforms: a day of 10 platforms in <= 120 s (its linear share, 5 s per
hour), <= 4 GB; 20 platforms x 1 h in <= 60 s, <= 2 GB (scaled the same way; the real
sizes: ``benchmarks/scale.py``). The targets say met or missed only when the run did the
work (_work.py: no pair passed through whose simulated dead reckoning can smooth, DI
recall >= 0.9), else "not comparable"; the work record is printed above them.

    python benchmarks/pipeline.py                         # 10 x 0.25 h, both modes
    python benchmarks/pipeline.py --hours 1 --mode cli --cache ~/.cache/coopproc-bench
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import count_lines, load, run_cli, session_dir, target
from _work import WORK_HEAD, WORK_NOTE, read_work, verdict

from coopproc.checks.coverage import prepare_run
from coopproc.io import read_session
from coopproc.run.config import RunConfig
from coopproc.run.output import write_run
from coopproc.run.pipeline import run_pipeline
from coopproc.run.summary import summarize

#: the second write of the tables (left out of the total)
AGAIN = "  of which tables (written again)"
#: platforms -> (seconds per hour of session, peak GB)
GOALS = {10: (120.0 / 24.0, 4.0), 20: (60.0, 2.0)}


def in_process(session_path: Path, out: Path, figures: bool) -> dict[str, float]:
    """Seconds of each step of ``coopproc run``, in this process."""
    config = RunConfig()
    config = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=figures))
    phases: dict[str, float] = {}

    def timed(label: str, fn: Callable[[], Any]) -> Any:
        start = time.perf_counter()
        result = fn()
        phases[label] = time.perf_counter() - start
        return result

    started = dt.datetime.now(dt.UTC)
    session = timed("read + validate", lambda: read_session(session_path))
    session, _ = timed("prepare_run", lambda: prepare_run(session))
    output = timed("stage chain", lambda: run_pipeline(session, config))
    for label, seconds in output.timings_s.items():
        phases[f"  {label}"] = seconds
    summary = timed("summary", lambda: summarize(output))

    def write(config: RunConfig, out: Path) -> None:
        write_run(output, session, config, out, force=True, started=started, summary=summary.facts)

    timed("write tables" + (", figures, HTML" if figures else ""), lambda: write(config, out))
    if figures:  # the tables alone, written once more to tell them from the figures
        tables = dataclasses.replace(config, run=dataclasses.replace(config.run, figures=False))
        timed(AGAIN, lambda: write(tables, out.with_name("t")))
    return phases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=0.25)
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--mode", choices=("both", "in-process", "cli"), default="both")
    parser.add_argument("--no-figures", action="store_true")
    parser.add_argument("--repeat", type=int, default=1, help="CLI runs (median wall time)")
    parser.add_argument("--cache", type=Path, help="keep the simulated sessions here")
    args = parser.parse_args()

    path = session_dir(args.hours, args.platforms, args.cache)
    n_ranges = count_lines(path / "ranges.csv") - 1
    what = f"{args.platforms} x {args.hours:g} h"
    print(f"large: {what}, {n_ranges:,} ranges, figures {'off' if args.no_figures else 'on'}")
    goal = GOALS.get(args.platforms)
    with tempfile.TemporaryDirectory(prefix="coopproc-pipeline-") as tmp:
        small = session_dir(0.02, 3, args.cache)
        wall, how, done = None, "", Path(tmp) / "out"
        if args.mode in ("both", "in-process"):
            in_process(small, Path(tmp) / "warm", figures=False)  # numba compile / cache load
            start = time.perf_counter()
            phases = in_process(path, Path(tmp) / "out", figures=not args.no_figures)
            total = time.perf_counter() - start - phases.get(AGAIN, 0.0)
            print(f"in process ({load()}):")
            for label, seconds in phases.items():
                print(f"  {label:<34} {seconds:7.2f} s")
            print(f"  {'total':<34} {total:7.2f} s  {n_ranges / total:,.0f} ranges/s")
            wall, how = total, "in process"
        if args.mode in ("both", "cli"):
            extra = ["--no-figures"] if args.no_figures else []
            run_cli(["run", str(small), "-o", f"{tmp}/warm_cli", "--force", *extra])
            runs = [
                run_cli(["run", str(path), "-o", f"{tmp}/cli", "--force", *extra])
                for _ in range(args.repeat)
            ]
            for r in runs:
                if r.returncode != 0:
                    raise SystemExit(f"coopproc run failed:\n{r.stderr[-2000:]}")
            wall, how = sorted(r.seconds for r in runs)[len(runs) // 2], "CLI"
            done = Path(tmp) / "cli"
            peak = max(r.peak_bytes for r in runs) / 1e9
            info = json.loads((Path(tmp) / "cli" / "run.json").read_text())
            timed = sum(info.get("timings_s", {}).values())
            print(f"coopproc run as a new process ({load()}):")
            print(
                f"  {'wall time (fork to exit)':<34} {wall:7.2f} s  {n_ranges / wall:,.0f} ranges/s"
            )
            print(f"  peak RSS                           {peak:7.2f} GB")
            print(f"  {'run.json duration_s':<34} {float(info.get('duration_s', 'nan')):7.2f} s")
            print(f"  run.json timings_s, sum            {timed:7.2f} s")
        work = read_work(done, path)
        why = verdict(work)
        print(f"work ({how}):\n{WORK_HEAD}\n{work.cells()}\n{WORK_NOTE}")
        print(f"  {why or 'complete'}")
        if goal is not None and args.mode in ("both", "cli"):
            print(target(f"{what} <= {goal[1]:g} GB", peak, goal[1], at_most=True, incomplete=why))
        if goal is not None and wall is not None:
            limit = goal[0] * args.hours
            # the day target's linear share: stricter than the target on short sessions,
            # where fixed costs (process start, figure layout) weigh most
            share = f"pace {what} <= {limit:.3g} s ({goal[0]:g} s per hour; {how})"
            print(target(share, wall, limit, at_most=True, incomplete=why))


if __name__ == "__main__":
    main()
