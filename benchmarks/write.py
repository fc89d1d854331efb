"""Benchmark writing a positions.csv-like table: pandas ``to_csv`` against coopproc's writer.

The table (``--rows``, default 2,000,000): ``time`` (seconds of a day from 1.7e9, 100 Hz),
``platform`` and ``method`` (text), eight float columns (``east, north, up, error_h``,
four sigmas; 5 % empty), one int column. Timed, each the median of ``--repeat`` runs
after a warm-up (numba compiled or loaded from its cache):

- the peer: ``DataFrame.to_csv(index=False, float_format="%.6f", lineterminator="\\n")``,
  what ``coopproc.io.outdir.write_csv`` called before;
- ``write_csv`` (the compiled writer of coopproc.io.csv_fast), checked to give the same
  bytes; and its text alone (no file written), to tell formatting from the disk;
- with pyarrow installed: the table as Parquet (``coopproc run --format parquet``).

Target (issue 11): ``write_csv`` >= 1,000,000 rows/s.

    python benchmarks/write.py
    python benchmarks/write.py --rows 500000 --repeat 5
"""

from __future__ import annotations

import argparse
import hashlib
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from _common import load, median_seconds, spread, target

from coopproc.io.csv_fast import csv_chunks
from coopproc.io.outdir import FLOAT_FORMAT, write_csv

TARGET_ROWS_PER_S = 1_000_000


def positions_like(rows: int, seed: int = 0) -> pd.DataFrame:
    """The benchmark table (module doc)."""
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame(
        {
            "time": 1.7e9 + np.arange(rows) * 0.01,
            "platform": rng.choice([f"P{k:02d}" for k in range(10)], rows),
            "method": rng.choice(["observed", "di", "rn", "nav", "reference"], rows),
        }
    )
    for name in ("east", "north", "up", "error_h", "sigma_e", "sigma_n", "sigma_u", "sigma_h"):
        values = rng.normal(0.0, 300.0, rows)
        values[rng.random(rows) < 0.05] = np.nan
        frame[name] = values
    frame["n"] = rng.integers(0, 1000, rows)
    return frame


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    frame = positions_like(args.rows)
    print(f"positions-like table: {args.rows:,} rows x {frame.shape[1]} columns ({load()})")
    with tempfile.TemporaryDirectory(prefix="coopproc-bench-write-") as tmp:
        old, new = Path(tmp) / "pandas.csv", Path(tmp) / "coopproc.csv"

        def peer() -> None:
            frame.to_csv(old, index=False, float_format=FLOAT_FORMAT, lineterminator="\n")

        t_old, all_old = median_seconds(peer, args.repeat)
        print(
            f"pandas to_csv:  {t_old:7.3f} s  {args.rows / t_old:12,.0f} rows/s  "
            f"({spread(all_old)}; {load()})"
        )
        t_new, all_new = median_seconds(lambda: write_csv(frame, new), args.repeat)
        print(
            f"write_csv:      {t_new:7.3f} s  {args.rows / t_new:12,.0f} rows/s  "
            f"({spread(all_new)}; {load()})  {t_old / t_new:.1f}x pandas"
        )
        pieces = lambda: sum(len(p) for p in csv_chunks(frame) or ())  # noqa: E731
        t_fmt, all_fmt = median_seconds(pieces, args.repeat)
        print(
            f"  of which text: {t_fmt:7.3f} s  {args.rows / t_fmt:12,.0f} rows/s  "
            f"({spread(all_fmt)}; formatting only, no file; {load()})"
        )
        same = _sha(old) == _sha(new)
        print(f"same bytes as pandas: {'yes' if same else 'NO'} ({new.stat().st_size:,} bytes)")
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            print("parquet: pyarrow not installed (pip install pyarrow)")
        else:
            from coopproc.io.parquet import write_parquet

            parquet = Path(tmp) / "coopproc.parquet"
            t_pq, all_pq = median_seconds(lambda: write_parquet(frame, parquet), args.repeat)
            print(
                f"write_parquet:  {t_pq:7.3f} s  {args.rows / t_pq:12,.0f} rows/s  "
                f"({spread(all_pq)}; {load()})  {parquet.stat().st_size:,} bytes"
            )
    rate = args.rows / t_new
    print(
        target(f">= {TARGET_ROWS_PER_S:,} rows/s", rate, TARGET_ROWS_PER_S, at_most=False)
        + ("" if same else " (but the bytes differ from pandas)")
    )


if __name__ == "__main__":
    main()
