"""Score a `coopproc run` of real TIERS against issue 30.8's "sustained spans".

The spans are the session's `truth/nlos.csv` rows with at least 3 epochs and a mean
excess of at least 3 sigma (sigma = session.toml's `[uwb] sigma`, 0.121 m): 23 on
`../shared/data/real/tiers`. A span counts as detected by a method when one of its
events (nlos_events.csv) overlaps it; the fusion's IGG-III decisions (range_weights.csv,
the observed fusion) count when a range inside the span is down-weighted / rejected.

    coopproc run ../shared/data/real/tiers -o out/tiers
    python benchmarks/tiers_spans.py out/tiers [--session ../shared/data/real/tiers] [-v]
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import pandas as pd

DEFAULT_SESSION = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "real" / "tiers"


def sustained_spans(session: Path) -> pd.DataFrame:
    sigma = tomllib.loads((session / "session.toml").read_text())["uwb"]["sigma"]
    truth = pd.read_csv(session / "truth" / "nlos.csv")
    return truth[(truth["epochs"] >= 3) & (truth["mean"] >= 3.0 * sigma)].reset_index(drop=True)


def overlaps(rows: pd.DataFrame, pair: str, start: float, end: float) -> bool:
    """True when a row of ``rows`` (pair, start, end) on ``pair`` overlaps [start, end]."""
    same = rows[rows["pair"] == pair]
    return bool(((same["start"] <= end) & (same["end"] >= start)).any())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("out", type=Path, help="the output directory of coopproc run")
    ap.add_argument("--session", type=Path, default=DEFAULT_SESSION)
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per span")
    args = ap.parse_args()
    spans = sustained_spans(args.session)
    truth = pd.read_csv(args.session / "truth" / "nlos.csv")
    events = pd.read_csv(args.out / "nlos_events.csv")
    weights = pd.read_csv(args.out / "range_weights.csv")
    weights = weights[weights["method"] == "observed"]
    on_tb4 = spans["pair"].str.contains("tb4")
    print(f"{len(spans)} sustained spans ({int(on_tb4.sum())} on tb4's pairs)")
    print(
        f"{'method':<24}{'detected':>10}{'tb4 pairs':>11}{'others':>8}{'events':>8}{'no span':>9}"
    )
    for method in ("di", "rn"):
        mine = events[events["method"] == method]
        hit = [overlaps(mine, s.pair, s.start, s.end) for s in spans.itertuples()]
        stray = sum(not overlaps(truth, e.pair, e.start, e.end) for e in mine.itertuples())
        hits = pd.Series(hit)
        print(
            f"{method:<24}{int(hits.sum()):>6} / {len(spans):<2}{int(hits[on_tb4].sum()):>8}"
            f"{int(hits[~on_tb4].sum()):>9}{len(mine):>8}{stray:>9}"
        )
        if args.verbose:
            t0 = float(truth["start"].min())
            for s, h in zip(spans.itertuples(), hit, strict=True):
                print(
                    f"    {s.pair} {s.start - t0:6.1f}-{s.end - t0:6.1f} s {s.epochs:4d} epochs "
                    f"mean {s.mean:.3f} m  {'found' if h else '-'}"
                )
    for label, col in (("fusion down-weighted", "gamma"), ("fusion rejected", "rejected")):
        hit = 0
        for s in spans.itertuples():
            inside = weights[
                (weights["pair"] == s.pair)
                & (weights["time"] >= s.start - 1e-6)
                & (weights["time"] <= s.end + 1e-6)
            ]
            hit += bool(
                (inside[col] < 1.0).any() if col == "gamma" else inside[col].astype(bool).any()
            )
        print(f"{label:<24}{hit:>6} / {len(spans)}")


if __name__ == "__main__":
    main()
