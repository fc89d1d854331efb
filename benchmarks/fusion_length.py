"""The fused error against the recording's length (issue 29): 15 min, 2 h and 8 h.

The simulator's ``paper-experiment`` (three platforms, the leader with GNSS/INS, two
INS/odometer followers with gyro biases up to 2.7 deg/h and 0.3 % odometer scale, UWB at
1 Hz, the paper's four NLOS events in the first 10 minutes) is simulated once for the
longest duration asked; each shorter session is its first part (the same noise, cut
from the files), so the recordings differ only in how long they go on. Each runs through
``coopproc run`` (a new process) with ``[fusion] state = "dr"`` (the default) and
``"position"`` (paper 000's own fusion). Printed per follower and state: the mean
horizontal error of the observed fusion over the first and the last 15 minutes and over
the whole recording, its own navigation's, and the two targets:

- the last 15 minutes within 1.3 x the first 15 minutes' (bounded error);
- the whole recording's mean within 1.3 x the 15-minute recording's.

    python benchmarks/fusion_length.py                 # 15 min, 2 h, 8 h
    python benchmarks/fusion_length.py --hours 0.25,2 --seed 1
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import pandas as pd
from _common import CliRun, load, run_cli, target

QUARTER_S = 900.0


def _cut(session: Path, to: Path, seconds: float) -> None:
    """The first ``seconds`` of a simulated session (CSV navigation and ranges, RTKLIB
    .pos reference at 5 Hz)."""
    to.mkdir(parents=True)
    (to / "session.toml").write_text((session / "session.toml").read_text())
    ranges = pd.read_csv(session / "ranges.csv")
    t0 = float(ranges["time"].min())
    ranges[ranges["time"] < t0 + seconds].to_csv(to / "ranges.csv", index=False)
    for nav in session.glob("nav_*.csv"):
        frame = pd.read_csv(nav)
        frame[frame["time"] < t0 + seconds + 1.0].to_csv(to / nav.name, index=False)
    for ref in session.glob("ref_*.pos"):
        lines = ref.read_text().splitlines(keepends=True)
        head = [line for line in lines if line.startswith("%")]
        body = [line for line in lines if not line.startswith("%")]
        (to / ref.name).write_text("".join(head + body[: int((seconds + 1.0) * 5)]))


def _means(positions: pd.DataFrame, platform: str, method: str) -> tuple[float, float, float]:
    rows = positions[(positions["platform"] == platform) & (positions["method"] == method)]
    t = rows["time"]
    first = rows[t < t.min() + QUARTER_S]["error_h"].mean()
    last = rows[t > t.max() - QUARTER_S]["error_h"].mean()
    return float(first), float(last), float(rows["error_h"].mean())


def _cli(args: list[str]) -> CliRun:
    run = run_cli(args)
    if run.returncode != 0:
        raise SystemExit(f"coopproc {args[0]} failed: {run.stderr.strip().splitlines()[-1:]}")
    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", default="0.25,2,8", help="recording lengths, h")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    hours = sorted(float(h) for h in args.hours.split(","))
    root = Path(tempfile.mkdtemp(prefix="coopproc-length-"))
    longest = root / "sim"
    sim = _cli(
        ["simulate", str(longest), "--scenario", "paper-experiment", "--seed", str(args.seed),
         "--duration", f"{hours[-1] * 3600:g}"]
    )  # fmt: skip
    print(f"simulated paper-experiment seed {args.seed}, {hours[-1]:g} h: {sim.seconds:.1f} s")
    config = root / "position.toml"
    config.write_text('[fusion]\nstate = "position"\n')
    results: dict[tuple[float, str], pd.DataFrame] = {}
    for h in hours:
        session = longest if h == hours[-1] else root / f"cut_{h:g}h"
        if h != hours[-1]:
            _cut(longest, session, h * 3600)
        for state in ("dr", "position"):
            out = root / f"out_{h:g}h_{state}"
            extra = [] if state == "dr" else ["--config", str(config)]
            run = _cli(["run", str(session), "-o", str(out), "--no-figures", *extra])
            print(f"  {h:g} h, state {state!r}: coopproc run {run.seconds:.1f} s ({load()})")
            results[h, state] = pd.read_csv(out / "positions.csv")
    print()
    print("mean horizontal error of the observed fusion (m): first 15 min / last 15 min / all")
    for state in ("dr", "position"):
        for platform in ("A", "C"):
            cells = []
            for h in hours:
                first, last, whole = _means(results[h, state], platform, "observed")
                cells.append(f"{h:g} h {first:.3f} / {last:.3f} / {whole:.3f}")
            nav = _means(results[hours[-1], state], platform, "nav")
            print(
                f"  {state:<8} {platform}: " + ";  ".join(cells)
                + f";  own nav {hours[-1]:g} h {nav[0]:.3f} / {nav[1]:.3f} / {nav[2]:.3f}"
            )  # fmt: skip
    print()
    short = hours[0]
    for h in hours[1:]:
        for platform in ("A", "C"):
            first, last, whole = _means(results[h, "dr"], platform, "observed")
            quarter = _means(results[short, "dr"], platform, "observed")[2]
            print(target(
                f"{h:g} h {platform}: last 15 min {last:.3f} <= 1.3 x first {first:.3f} m",
                last, 1.3 * first, at_most=True,
            ))  # fmt: skip
            print(target(
                f"{h:g} h {platform}: mean {whole:.3f} <= 1.3 x the {short:g} h recording's "
                f"{quarter:.3f} m", whole, 1.3 * quarter, at_most=True,
            ))  # fmt: skip


if __name__ == "__main__":
    main()
