"""How ``coopproc run`` scales with duration and platforms (issue 11, item 4).

Simulates the ``large`` scenario (seed 0: nav 10 Hz, every pair ranging at 1 Hz with
staggered polling, 5 Hz reference) and runs the real CLI, ``python -m coopproc run
SESSION -o OUT --force``, as a new process for each session: wall time from the fork to
the exit (process start, imports, numba cache loads, reading, the chain, tables, figures
and HTML), the child's peak RSS (``os.wait4``) and the peak PSS sum of the child and its
forked workers (sampled; the memory targets use the larger), and each phase that run.json
``timings_s`` lists, with its rows per second. Then the growth exponents (log-log slope
between the duration points, and between the platform counts against platforms and
against ranges) and one line per target.

    python benchmarks/scale.py             # 1 h x 10, 4 h x 10, 1 h x 20 platforms
    python benchmarks/scale.py --quick     # 0.25 h and 0.5 h x 10, 0.5 h x 20 (a few minutes)
    python benchmarks/scale.py --day       # also 24 h x 10 (the issue's 120 s / 4 GB target)
    python benchmarks/scale.py --thirty    # also 1 h x 30 platforms
    python benchmarks/scale.py --sessions 0.25x10,1x10 --cache ~/.cache/coopproc-bench \\
        --run-args=--no-figures

Each session is simulated once per ``--cache`` directory (without it: a temporary one).
Runs are three per session (``--repeat``): the table shows the median wall time and peak
and their spread (min-max); a 24 h run takes minutes. Mind the memory: before issue 11,
4 h x 10 needed about 5 GB and 20 x 1 h 14 GB.

Next to time and memory, what each run did (issue 35, _work.py): DI and RN pairs per mode
(smoothing / ranges-only / passed through), NLOS events found / simulated / false against
the simulator's truth, the rn and di fusions run or reused. A target says met or missed
only when every run of its session did the full work (no pair passed through whose
simulated dead reckoning can smooth, DI recall >= 0.9); else "not comparable: <reason>".
``--workload dense``: another seed and eight times the NLOS events (WORKLOADS).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import shlex
import statistics
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from _common import count_lines, load, run_cli, session_dir, target
from _work import WORK_HEAD, WORK_NOTE, Work, read_work, smoothable_pairs, verdict

DEFAULT = ((1.0, 10), (4.0, 10), (1.0, 20))
QUICK = ((0.25, 10), (0.5, 10), (0.5, 20))
GB = 1e9
#: The sessions' simulation: ``large`` as every benchmark uses it (seed 0, 0.5 random NLOS
#: events per pair-hour); ``dense``: seed 1 and 4 events per pair-hour (10-30 s each, so
#: up to 3 % of a pair's time in NLOS), the detection and both fusions under more load.
WORKLOADS: dict[str, dict[str, Any]] = {
    "large": {"seed": 0},
    "dense": {"seed": 1, "random_nlos_per_pair_hour": 4.0},
}


@dataclass
class Result:
    hours: float
    platforms: int
    ranges: int = 0
    input_rows: int = 0
    output_rows: int = 0
    seconds: list[float] = field(default_factory=list)
    rss: list[int] = field(default_factory=list)
    tree: list[int] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    #: per run, each phase's peak PSS sum (_common.CliRun.phase_peak_bytes)
    phase_peaks: list[dict[str, int]] = field(default_factory=list)
    load: str = ""
    #: what each run did (_work.py), one per run
    works: list[Work] = field(default_factory=list)

    @property
    def incomplete(self) -> str | None:
        """Why the session's figures are not comparable with a target (None: every run
        did the full work)."""
        reasons = [v for v in (verdict(w) for w in self.works) if v]
        if not self.works:
            return "no work record"
        return reasons[0] if reasons else None

    @property
    def name(self) -> str:
        return f"{self.platforms} x {self.hours:g} h"

    @property
    def wall(self) -> float:
        return statistics.median(self.seconds)

    @property
    def peaks(self) -> list[int]:
        """Per run, the larger of the process's own peak RSS and the process tree's peak
        PSS (forked workers included, shared pages once)."""
        return [
            max(rss, tree) for rss, tree in itertools.zip_longest(self.rss, self.tree, fillvalue=0)
        ]

    @property
    def peak(self) -> float:
        """The median over the runs of :attr:`peaks`."""
        return statistics.median(self.peaks)


def parse_sessions(text: str) -> list[tuple[float, int]]:
    out = []
    for part in text.split(","):
        hours, _, platforms = part.strip().partition("x")
        out.append((float(hours), int(platforms)))
    return out


def phase_rows(label: str, r: Result) -> int:
    """What a phase's rows/s counts: input rows for reading, output CSV rows for writing
    tables, range rows (the session's ranges) for everything else."""
    low = label.lower()
    if low.startswith("read"):
        return r.input_rows
    if "table" in low or "csv" in low:
        return r.output_rows
    return r.ranges


def run_one(
    hours: float, platforms: int, args: argparse.Namespace, out_root: Path, extra: list[str]
) -> Result:
    session = session_dir(hours, platforms, args.cache, **WORKLOADS[args.workload])
    can = smoothable_pairs(session)
    r = Result(hours, platforms)
    r.ranges = count_lines(session / "ranges.csv") - 1
    r.input_rows = sum(
        count_lines(p) for p in session.iterdir() if p.suffix in (".csv", ".pos") and p.is_file()
    )
    out = out_root / f"out_{platforms}_{hours:g}"
    r.load = load()
    for _ in range(args.repeat):
        res = run_cli(["run", str(session), "-o", str(out), "--force", *extra])
        if res.returncode != 0:
            sys.exit(f"coopproc run {session} failed ({res.returncode}):\n{res.stderr[-2000:]}")
        r.seconds.append(res.seconds)
        r.rss.append(res.peak_rss_bytes)
        r.tree.append(res.peak_tree_bytes)
        r.phase_peaks.append(res.phase_peak_bytes)
        r.works.append(read_work(out, session, can))
    info = json.loads((out / "run.json").read_text())
    r.timings = {k: float(v) for k, v in info.get("timings_s", {}).items()}
    r.output_rows = sum(count_lines(p) - 1 for p in out.glob("*.csv"))
    print(
        f"  {r.name}: {r.ranges:,} ranges, {r.wall:.1f} s, {r.peak / GB:.2f} GB ({r.load}); "
        f"work: {r.incomplete or 'complete'}",
        file=sys.stderr,
    )
    return r


def slope(x0: float, x1: float, y0: float, y1: float) -> float:
    return math.log(y1 / y0) / math.log(x1 / x0)


def print_tables(results: list[Result]) -> None:
    print(
        f"{'session':<12}{'ranges':>11}{'runs':>5}{'wall s':>8}{'spread':>13}{'peak GB':>8}"
        f"{'spread':>11}{'RSS GB':>7}{'tree GB':>8}{'timed s':>8}{'ranges/s':>10}{WORK_HEAD}"
        "  load (1, 5, 15 min)"
    )
    for r in results:
        timed = sum(r.timings.values())
        walls = f"{min(r.seconds):.1f}-{max(r.seconds):.1f}"
        peaks = f"{min(r.peaks) / GB:.2f}-{max(r.peaks) / GB:.2f}"
        print(
            f"{r.name:<12}{r.ranges:>11,}{len(r.seconds):>5}{r.wall:>8.1f}{walls:>13}"
            f"{r.peak / GB:>8.2f}{peaks:>11}{max(r.rss) / GB:>7.2f}"
            f"{max(r.tree, default=0) / GB:>8.2f}{timed:>8.1f}{r.ranges / r.wall:>10,.0f}"
            f"{r.works[0].cells()}  {r.load.removeprefix('load ')}"
        )
    print("(wall s, peak GB: medians over the runs, spread min-max; peak: the larger of RSS,")
    print(" the main process's own peak (os.wait4), and tree, the peak PSS sum of the process")
    print(" and its forked workers sampled every 0.2 s; RSS and tree GB: the largest run's)")
    print("(timed s: the sum of run.json timings_s of the last run; the rest is untimed)")
    print(WORK_NOTE)
    print(" work of the first run; every run is checked:")
    for r in results:
        print(f"  {r.name}: {r.incomplete or 'complete'} ({r.works[0].smoothable} of "
              f"{r.works[0].pairs} pairs can smooth by the truth)")  # fmt: skip
    labels: list[str] = []
    for r in results:
        labels += [k for k in r.timings if k not in labels]
    print()
    print("phase (run.json timings_s): seconds, rows/s, peak GB")
    head = "".join(f"{r.name:>30}" for r in results)
    print(f"{'phase':<26}{head}")
    for label in labels:
        cells = ""
        for r in results:
            s = r.timings.get(label)
            if s is None:
                cells += f"{'-':>30}"
            else:
                rate = phase_rows(label, r) / s if s > 0 else float("inf")
                peak = phase_peak(r, label)
                shown = f"{peak / GB:>6.2f} GB" if peak is not None else f"{'-':>9}"
                cells += f"{s:>8.2f} s {rate:>10,.0f}/s{shown}"
        print(f"{label[:25]:<26}{cells}")
    print("(rows: reading = input rows, writing tables = output CSV rows, else ranges;")
    print(" peak GB: the largest PSS sum of the process tree sampled while the phase ran,")
    print(" median over the runs; the first phase includes the start-up)")


def phase_peak(r: Result, label: str) -> float | None:
    """The median over the runs of ``label``'s peak PSS sum (None: never sampled)."""
    peaks = [run[label] for run in r.phase_peaks if label in run]
    return statistics.median(peaks) if peaks else None


def exponents(results: list[Result]) -> list[tuple[str, float, float]]:
    """(what, time exponent, memory exponent) between successive points."""
    out = []
    by_p: dict[int, list[Result]] = {}
    by_h: dict[float, list[Result]] = {}
    for r in results:
        by_p.setdefault(r.platforms, []).append(r)
        by_h.setdefault(r.hours, []).append(r)
    for platforms, rs in sorted(by_p.items()):
        rs = sorted(rs, key=lambda r: r.hours)
        spans = list(itertools.pairwise(rs))
        if len(rs) > 2:  # the widest span too: fixed costs weigh least there
            spans.append((rs[0], rs[-1]))
        for a, b in spans:
            what = f"duration {a.hours:g} -> {b.hours:g} h, {platforms} platforms"
            out.append(
                (
                    what,
                    slope(a.hours, b.hours, a.wall, b.wall),
                    slope(a.hours, b.hours, a.peak, b.peak),
                )
            )
    for hours, rs in sorted(by_h.items()):
        rs = sorted(rs, key=lambda r: r.platforms)
        for a, b in itertools.pairwise(rs):
            for x0, x1, unit in (
                (a.platforms, b.platforms, "platforms"),
                (a.ranges, b.ranges, "ranges"),
            ):
                what = f"{unit} {a.platforms} -> {b.platforms} platforms, {hours:g} h"
                out.append((what, slope(x0, x1, a.wall, b.wall), slope(x0, x1, a.peak, b.peak)))
    return out


def print_targets(results: list[Result]) -> None:
    find = {(r.hours, r.platforms): r for r in results}
    goals = (((24.0, 10), 120.0, 4.0, "--day"), ((1.0, 20), 60.0, 2.0, ""))
    for (hours, platforms), seconds, gb, flag in goals:
        what = f"{platforms} x {hours:g} h <= {seconds:g} s"
        r = find.get((hours, platforms))
        if r is None:
            hint = f" (use {flag})" if flag else ""
            print(f"target {what} and <= {gb:g} GB: not run{hint}")
            continue
        why = r.incomplete
        print(target(what, r.wall, seconds, at_most=True, incomplete=why))
        memory = f"{platforms} x {hours:g} h <= {gb:g} GB"
        print(target(memory, r.peak / GB, gb, at_most=True, incomplete=why))
    if (1.0, 30) in find:
        r = find[(1.0, 30)]
        print(target("30 x 1 h completes within 24 GB", r.peak / GB, 24.0, at_most=True,
                     incomplete=r.incomplete))  # fmt: skip
    # with duration: over the widest span of each platform count (fixed costs such as
    # process start and figure layout weigh least there)
    by_p: dict[int, list[Result]] = {}
    for r in results:
        by_p.setdefault(r.platforms, []).append(r)
    for platforms, rs in sorted(by_p.items()):
        if len(rs) < 2:
            continue
        a, b = min(rs, key=lambda r: r.hours), max(rs, key=lambda r: r.hours)
        span = f"{a.hours:g} -> {b.hours:g} h, {platforms} platforms"
        t_exp = slope(a.hours, b.hours, a.wall, b.wall)
        m_exp = slope(a.hours, b.hours, a.peak, b.peak)
        why = "; ".join(f"{x.name}: {x.incomplete}" for x in (a, b) if x.incomplete) or None
        for kind, value in (("time", t_exp), ("memory", m_exp)):
            what = f"{kind} exponent with duration <= 1.1 ({span})"
            print(target(what, value, 1.1, at_most=True, incomplete=why))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sessions, a few minutes")
    parser.add_argument("--day", action="store_true", help="also 24 h x 10 platforms")
    parser.add_argument("--thirty", action="store_true", help="also 1 h x 30 platforms")
    parser.add_argument(
        "--sessions", help="instead: comma-separated HOURSxPLATFORMS, e.g. 0.25x10,1x10"
    )
    parser.add_argument("--cache", type=Path, help="keep the simulated sessions here")
    parser.add_argument("--out", type=Path, help="keep the run outputs here (default: temp)")
    parser.add_argument(
        "--run-args",
        default="",
        help="extra `coopproc run` arguments, e.g. --run-args=--no-figures",
    )
    parser.add_argument(
        "--repeat", type=int, default=3, help="runs per session (median and spread)"
    )
    parser.add_argument(
        "--workload",
        choices=sorted(WORKLOADS),
        default="large",
        help="large: seed 0, 0.5 NLOS events per pair-hour; dense: seed 1, 4 per pair-hour",
    )
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args()

    sessions = list(QUICK if args.quick else DEFAULT)
    if args.sessions:
        sessions = parse_sessions(args.sessions)
    if args.day:
        sessions.append((24.0, 10))
    if args.thirty:
        sessions.append((1.0, 30))
    extra = shlex.split(args.run_args)
    sim = ", ".join(f"{k} {v:g}" for k, v in WORKLOADS[args.workload].items())
    print(
        f"{' '.join(['coopproc run', *extra])} on the large scenario, workload "
        f"{args.workload} ({sim}), {args.repeat} run(s) per session ({load()})"
    )
    with tempfile.TemporaryDirectory(prefix="coopproc-scale-") as tmp:
        out_root = args.out or Path(tmp)
        # one small run first: numba compiles into its cache (or loads it), as any
        # run after the first one on a machine does
        warm = run_cli(
            ["run", str(session_dir(0.02, 3, args.cache)), "-o", f"{tmp}/warm", "--force", *extra]
        )
        print(f"warm-up run (3 x 0.02 h): {warm.seconds:.1f} s", file=sys.stderr)
        results = [run_one(h, p, args, out_root, extra) for h, p in sessions]
    print_tables(results)
    slopes = exponents(results)
    if slopes:
        print()
        print(f"{'growth exponent (log-log slope)':<52}{'time':>7}{'memory':>8}")
        for what, t_exp, m_exp in slopes:
            print(f"{what:<52}{t_exp:>7.2f}{m_exp:>8.2f}")
        print("(against ranges, 1.0 is linear in the data; against platforms, 2.0 is)")
    print()
    print_targets(results)
    if args.json:
        rows = [
            {
                "hours": r.hours,
                "platforms": r.platforms,
                "ranges": r.ranges,
                "wall_s": r.seconds,
                "peak_rss_bytes": r.rss,
                "peak_tree_pss_bytes": r.tree,
                "timings_s": r.timings,
                "phase_peak_pss_bytes": r.phase_peaks,
                "load": r.load,
                "work": [w.as_dict() for w in r.works],
                "not_comparable": r.incomplete,
            }
            for r in results
        ]
        doc = {"run_args": extra, "workload": args.workload, "sessions": rows}
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
