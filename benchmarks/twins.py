"""Twins of the real sessions: the same real ranges and reference, the dead reckoning drawn again.

`real/tiers` and `real/miluv1` have no recorded navigation: their ``nav_<ID>.csv`` is the
mocap trajectory degraded by a seeded synthetic drift, whose recipe their README gives
(the horizontal increments scaled by 1 +- U(1, 3) % and rotated by a heading error growing
at +-U(2, 5) deg/min, + 0.05 deg/sqrt(s) random walk and U(-0.5, 0.5) deg initial; a
constant velocity bias N(0, 1 cm/s) per axis, a 3 cm initial offset, 1 cm white noise; up
= the mocap's + 3 cm + 1 cm noise). This script draws that recipe with other seeds, so a
session's ranges are judged with dead reckoning the defaults were not chosen on: the
twins a user's own recording of the same place would be. Each follower's ``drift_sigma``
in session.toml is recomputed the README's way (the RMS per-axis 1 s change of the nav's
horizontal error against the truth). Everything else is copied as is.

Per twin, through ``coopproc run --no-figures`` (a new process), the real-data targets of
issue 30.8: the share of pairs whose DI RMSE is at most 1.05 x the observed and the
largest ratio; the DI false-alarm rate of the worst pair (flagged epochs outside
``truth/nlos.csv``'s spans over the epochs outside them); per follower DI-fused /
observed-fused and observed-fused / own navigation (mean horizontal error).

    python benchmarks/twins.py                         # tiers and miluv1, seeds 1-3
    python benchmarks/twins.py ../shared/data/real/miluv1 --seeds 1,2,3,4,5 --keep DIR
"""

from __future__ import annotations

import argparse
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from _common import run_cli

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"


def make_twin(src: Path, seed: int, dst: Path) -> dict[str, float]:
    """Write the twin of session ``src`` drawn with ``seed`` to ``dst``; returns each
    follower's new drift_sigma (m/s)."""
    shutil.copytree(src, dst)
    rng = np.random.default_rng(1000 + seed)
    toml = (dst / "session.toml").read_text()
    drift = {}
    for nav in sorted(src.glob("nav_*.csv")):
        pid = nav.stem[4:]
        old = pd.read_csv(nav)
        true = pd.read_csv(src / "truth" / f"true_{pid}.csv")
        t = old["time"].to_numpy(dtype=np.float64)
        east, north, up = (np.interp(t, true["time"], true[c]) for c in ("east", "north", "up"))
        scale = rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 0.03)
        rate = rng.choice([-1.0, 1.0]) * rng.uniform(2.0, 5.0) / 60.0  # deg/s
        start = rng.uniform(-0.5, 0.5)
        dt = np.diff(t, prepend=t[0])
        heading = np.deg2rad(
            start + rate * (t - t[0]) + np.cumsum(rng.normal(0.0, 0.05, t.size) * np.sqrt(dt))
        )
        de = np.diff(east, prepend=east[0])
        dn = np.diff(north, prepend=north[0])
        c, s = np.cos(heading), np.sin(heading)
        bias = rng.normal(0.0, 0.01, 2)
        angle = rng.uniform(0.0, 2.0 * np.pi)
        e = east[0] + 0.03 * np.cos(angle) + np.cumsum((1 + scale) * (c * de - s * dn))
        n = north[0] + 0.03 * np.sin(angle) + np.cumsum((1 + scale) * (s * de + c * dn))
        e = e + bias[0] * (t - t[0]) + rng.normal(0.0, 0.01, t.size)
        n = n + bias[1] * (t - t[0]) + rng.normal(0.0, 0.01, t.size)
        u = up + 0.03 + rng.normal(0.0, 0.01, t.size)
        frame = pd.DataFrame({"time": old["time"], "east": e, "north": n, "up": u})
        frame.round({"east": 4, "north": 4, "up": 4}).to_csv(dst / nav.name, index=False)
        lag = max(round(1.0 / float(np.median(np.diff(t)))), 1)
        err = np.stack([e - east, n - north])
        sigma = float(np.sqrt(np.mean((err[:, lag:] - err[:, :-lag]) ** 2)))
        drift[pid] = sigma
        toml = re.sub(
            rf'(\[platforms\.{pid}\]\nrole = "follower"\ndrift_sigma = )[0-9.]+',
            rf"\g<1>{sigma:.3f}",
            toml,
        )
    (dst / "session.toml").write_text(toml)
    return drift


def _flagged(times: np.ndarray, spans: pd.DataFrame) -> np.ndarray:
    inside = np.zeros(times.shape[0], dtype=bool)
    for start, end in zip(spans["start"], spans["end"], strict=True):
        inside |= (times >= start) & (times <= end)
    return inside


def score(out: Path, session: Path) -> str:
    """The issue 30.8 figures of one run (module doc), as one line."""
    ranges = pd.read_csv(out / "ranges.csv")
    events = pd.read_csv(out / "nlos_events.csv")
    events = events[events["method"] == "di"]
    rmse = pd.read_csv(out / "metrics.csv").set_index(["pair", "method"])["rmse"]
    fused = pd.read_csv(out / "position_metrics.csv").set_index(["platform", "method"])["mean"]
    truth = pd.read_csv(session / "truth" / "nlos.csv")
    ratios: list[float] = []
    far: list[float] = []
    for pair, group in ranges.groupby("pair"):
        ratios.append(rmse[(pair, "di")] / rmse[(pair, "observed")])
        times = group["time"].to_numpy()
        true = _flagged(times, truth[truth["pair"] == pair])
        mine = _flagged(times, events[events["pair"] == pair])
        far.append(float(np.count_nonzero(mine & ~true)) / max(int(np.count_nonzero(~true)), 1))
    ratio = np.array(ratios)
    fusion = " ".join(
        f"{p} {fused[(p, 'di')] / fused[(p, 'observed')]:.3f}/"
        f"{fused[(p, 'observed')] / fused[(p, 'nav')]:.3f}"
        for p in sorted({p for p, _ in fused.index})
        if {(p, "di"), (p, "observed"), (p, "nav")} <= set(fused.index)
    )
    return (
        f"DI/obs <= 1.05 on {np.mean(ratio <= 1.05):.0%} of pairs (max {ratio.max():.3f}); "
        f"worst DI false alarms {max(far):.1%}; DI-fused/obs-fused and obs-fused/nav: {fusion}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sessions", nargs="*", type=Path)
    parser.add_argument("--seeds", default="1,2,3", help="comma-separated seeds")
    parser.add_argument("--keep", type=Path, help="write the twins and runs here")
    args = parser.parse_args()
    sessions = args.sessions or [REAL / "tiers", REAL / "miluv1"]
    missing = [s for s in sessions if not (s / "truth" / "nlos.csv").exists()]
    if missing:
        raise SystemExit(f"no session with truth/nlos.csv at {missing[0]} (../shared/data?)")
    seeds = [int(s) for s in args.seeds.split(",")]
    root = args.keep or Path(tempfile.mkdtemp(prefix="coopproc-twins-"))
    try:
        for session in sessions:
            runs = [("shared", session)]
            for seed in seeds:
                twin = root / f"{session.name}_twin{seed}"
                if twin.exists():
                    shutil.rmtree(twin)
                drift = make_twin(session, seed, twin)
                print(
                    f"{twin.name}: drift_sigma "
                    + " ".join(f"{p} {v:.3f}" for p, v in sorted(drift.items()))
                )
                runs.append((f"twin {seed}", twin))
            for label, path in runs:
                out = root / f"out_{session.name}_{label.replace(' ', '')}"
                run = run_cli(["run", str(path), "-o", str(out), "--no-figures", "--force"])
                if run.returncode != 0:
                    print(f"{session.name} {label}: coopproc run failed: {run.stderr[-300:]}")
                    continue
                print(f"{session.name} {label}: {score(out, path)} ({run.seconds:.1f} s)")
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
