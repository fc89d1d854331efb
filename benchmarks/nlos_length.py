"""NLOS processing at every recording length (issue 30): the same hardware, longer sessions.

Simulates the ``large`` scenario (10 platforms, every pair ranging at 1 Hz, random NLOS
events at 0.5 per pair-hour, UWB white noise 0.080 m) at each duration, runs the real
CLI (``coopproc run --no-figures``) and prints per duration:

- pairs whose DI-Based calibration put any / every window in ranges-only mode (the DI too
  poor to smooth; before issue 30 a whole pair passed through, detecting nothing);
- true NLOS events, DI-Based and RN-Based events that overlap one (found), events that
  overlap none (false), false alarms per hour;
- the per-window white-noise estimate (run.json calibration) against the truth: median,
  10th and 90th percentile of estimate / 0.080 over all windows of all pairs.

    python benchmarks/nlos_length.py                 # 1 h and 4 h
    python benchmarks/nlos_length.py --hours 0.25,1  # quicker
    python benchmarks/nlos_length.py --day           # also 24 h (minutes, GBs)
    python benchmarks/nlos_length.py --cache ~/.cache/coopproc-bench
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from _common import load, run_cli, session_dir, target
from _work import overlaps

TRUE_SIGMA_M = 0.08  # SimParams.uwb_noise_m of the large scenario


def measure(hours: float, cache: Path | None, extra: list[str]) -> dict[str, float]:
    session = session_dir(hours, 10, cache)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        run = run_cli(["run", str(session), "-o", str(out), "--no-figures", "--force", *extra])
        if run.returncode != 0:
            raise SystemExit(f"coopproc run failed on {session}:\n{run.stderr}")
        info = json.loads((out / "run.json").read_text())
        events = pd.read_csv(out / "nlos_events.csv")
    truth = pd.read_csv(session / "truth" / "nlos_events.csv")
    ranging = info["calibration"]["ranging"]
    whites, any_ro, all_ro = [], 0, 0
    for facts in ranging.values():
        di = facts.get("di", {})
        fraction = di.get("ranges_only_fraction") or 0.0
        any_ro += fraction > 0
        all_ro += fraction >= 1.0
        whites += [w["white_sigma_m"] for w in di.get("windows", []) if w["estimated"]]
    ratio = np.asarray(whites, dtype=float) / TRUE_SIGMA_M
    row: dict[str, float] = {
        "hours": hours,
        "pairs": len(ranging),
        "ranges_only_any": any_ro,
        "ranges_only_all": all_ro,
        "true_events": len(truth),
        "seconds": run.seconds,
    }
    for method in ("di", "rn"):
        found, false = overlaps(events[events["method"] == method], truth)
        row[f"{method}_found"] = found
        row[f"{method}_false"] = false
        row[f"{method}_false_per_h"] = false / hours
    row["white_p10"], row["white_median"], row["white_p90"] = np.percentile(ratio, [10, 50, 90])
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", default="1,4", help="durations, comma separated")
    parser.add_argument("--day", action="store_true", help="also 24 h")
    parser.add_argument("--cache", type=Path, default=None, help="keep simulated sessions")
    parser.add_argument("--run-args", default="", help="extra arguments of coopproc run")
    args = parser.parse_args()
    hours = [float(h) for h in args.hours.split(",") if h]
    if args.day:
        hours.append(24.0)
    rows = [measure(h, args.cache, args.run_args.split()) for h in hours]
    print(f"large scenario, 10 platforms, seed 0 (load {load()})")
    print(
        f"{'hours':>6} {'pairs':>5} {'RO any/all':>10} {'true':>5} {'DI found/false':>14} "
        f"{'RN found/false':>14} {'white est/true p10 med p90':>27} {'wall s':>7}"
    )
    for r in rows:
        print(
            f"{r['hours']:>6g} {r['pairs']:>5.0f} "
            f"{r['ranges_only_any']:>4.0f}/{r['ranges_only_all']:<5.0f}"
            f" {r['true_events']:>5.0f} {r['di_found']:>7.0f}/{r['di_false']:<6.0f}"
            f" {r['rn_found']:>7.0f}/{r['rn_false']:<6.0f}"
            f" {r['white_p10']:>9.3f} {r['white_median']:>6.3f} {r['white_p90']:>6.3f}"
            f" {r['seconds']:>9.1f}"
        )
    for r in rows:
        name = f"{r['hours']:g} h"
        print(target(f"{name}: white-noise estimate within 10 % of truth (median)",
                     abs(r["white_median"] - 1.0), 0.10, at_most=True))  # fmt: skip
        recall = r["di_found"] / max(r["true_events"], 1)
        print(target(f"{name}: DI finds >= 90 % of the events", recall, 0.90, at_most=False))


if __name__ == "__main__":
    main()
