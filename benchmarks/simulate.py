"""Benchmark ``coopproc simulate``: every shipped scenario, and ``large`` at chosen sizes.

For each scenario (its default duration and platforms; ``large`` at each ``--large``
size, hours x platforms) two figures, each the median of ``--repeat`` runs after one
warm-up run: the simulation alone (``coopproc.sim.simulate`` in a child process: the
model, no files) and the command a user runs, ``coopproc simulate OUT --scenario S
--force`` as a new process (simulation + writing every file + start-up), with the
child's peak RSS; first, the start-up alone (a new process importing what the command
imports: scipy.signal is most of it). ``--mcap`` adds ``--mcap`` (the session once
more as one MCAP file). No target: docs/simulator.md and docs/benchmarks.md quote the numbers.

    python benchmarks/simulate.py
    python benchmarks/simulate.py --scenarios paper-experiment,large --large 1x10,1x20 --mcap
"""

from __future__ import annotations

import argparse
import datetime
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import load, median_seconds, run_cli, spread

from coopproc.sim import SCENARIOS


def _shapes(text: str) -> list[tuple[float, int]]:
    """``1x10,3x10`` -> [(1.0, 10), (3.0, 10)] (hours x platforms)."""
    out = []
    for item in filter(None, text.split(",")):
        hours, platforms = item.lower().split("x")
        out.append((float(hours), int(platforms)))
    return out


def _cases(names: list[str], large: list[tuple[float, int]]) -> list[tuple[str, list[str]]]:
    """(label, extra CLI options) per case; the default size of every scenario but
    ``large``, which runs at each ``large`` shape."""
    cases = []
    for name in names:
        if name != "large":
            cases.append((name, []))
            continue
        for hours, platforms in large:
            options = ["--duration", f"{hours * 3600:g}", "--platforms", str(platforms)]
            cases.append((f"large {platforms} x {hours:g} h", options))
    return cases


_ENGINE = """
import json, sys, time
from coopproc.sim import simulate
scenario, repeat, kwargs = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
simulate(scenario, seed=0, **kwargs)
times = []
for _ in range(repeat):
    start = time.perf_counter()
    simulate(scenario, seed=0, **kwargs)
    times.append(time.perf_counter() - start)
print(json.dumps(times))
"""


def _engine(name: str, options: list[str], repeat: int) -> tuple[float, list[float]]:
    """``simulate()`` alone, timed in a child process: this process stays small, so the
    children's peak RSS (inherited across fork on Linux) is the command's own."""
    kwargs: dict[str, float | int] = {}
    if options:
        kwargs = {"duration_s": float(options[1]), "platforms": int(options[3])}
    args = [name.split()[0], str(repeat), json.dumps(kwargs)]
    out = subprocess.run(
        [sys.executable, "-P", "-c", _ENGINE, *args], check=True, capture_output=True, text=True
    )
    times = [float(t) for t in json.loads(out.stdout)]
    return statistics.median(times), times


def _imports(repeat: int) -> tuple[float, list[float]]:
    """Seconds of a new process that only imports what ``coopproc simulate`` imports."""
    code = "import coopproc.cli.simulate, coopproc.sim.engine, coopproc.io"
    return median_seconds(
        lambda: subprocess.run([sys.executable, "-P", "-c", code], check=True), repeat=repeat
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma separated")
    parser.add_argument("--large", default="1x10,1x20", help="hours x platforms, e.g. 1x10")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--mcap", action="store_true", help="also write the MCAP file")
    args = parser.parse_args()
    names = [n for n in args.scenarios.split(",") if n]
    unknown = sorted(set(names) - set(SCENARIOS))
    if unknown:
        parser.error(f"unknown scenario(s) {unknown}; expected some of {list(SCENARIOS)}")
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    print(f"== simulate.py {now} ({load()}; median of {args.repeat} after 1 warm-up)")
    start, start_times = _imports(args.repeat)
    print(f"python start + imports of coopproc simulate: {start:.2f} s ({spread(start_times)})")
    print(f"{'scenario':<24} {'simulation':>10} {'coopproc simulate':>18} {'peak RSS':>9}")
    root = Path(tempfile.mkdtemp(prefix="coopproc-bench-sim-"))
    try:
        for label, options in _cases(names, _shapes(args.large)):
            engine, engine_times = _engine(label, options, args.repeat)
            out = root / "out"
            cli = ["simulate", str(out), "--scenario", label.split()[0], "--force", *options]
            cli += ["--mcap"] if args.mcap else []
            runs = []
            for _ in range(args.repeat + 1):
                run = run_cli(cli)
                if run.returncode != 0:
                    raise SystemExit(f"{' '.join(cli)} failed:\n{run.stderr}")
                runs.append(run)
            timed = runs[1:]
            cli_times = [r.seconds for r in timed]
            median = statistics.median(cli_times)
            rss = max(r.peak_rss_bytes for r in timed) / 1e6
            print(
                f"{label:<24} {engine:>8.2f} s {median:>16.2f} s {rss:>6.0f} MB  "
                f"(simulation {spread(engine_times)}; command {spread(cli_times)}; {load()})"
            )
    finally:
        shutil.rmtree(root, ignore_errors=True)
    print(f"== end {datetime.datetime.now(datetime.UTC).strftime('%Y-%m-%dT%H:%M:%SZ')}")


if __name__ == "__main__":
    main()
