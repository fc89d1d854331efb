"""Benchmark the clock-offset estimate (``coopproc.checks.clock.estimate_clock``).

Simulates the ``large`` scenario in memory (``coopproc.sim.simulate``: every pair at
1 Hz, nav 10 Hz, reference 5 Hz) at each ``--sizes`` entry (hours x platforms), moves the
second platform's navigation 50 ms late and every range 18 s early (a UTC range clock
against GPS navigation), and times ``estimate_clock`` (median of ``--repeat`` runs after a
warm-up), printing what it found against the truth (+18.050 s and +18.000 s for the
others' navigation against the ranges).

    python benchmarks/clock.py                 # 1 h x 10 and 24 h x 10 platforms
    python benchmarks/clock.py --sizes 1x10 --repeat 3
"""

from __future__ import annotations

import argparse
import time

from _common import load

from coopproc.checks.clock import apply_corrections, estimate_clock
from coopproc.sim import simulate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1x10,24x10", help="hours x platforms, comma separated")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    print(f"load {load()}")
    for item in args.sizes.split(","):
        hours, platforms = (float(v) for v in item.lower().split("x"))
        made = time.perf_counter()
        session = simulate("large", seed=0, duration_s=hours * 3600, platforms=int(platforms))
        session = session.session
        late = session.moving_platforms()[1]
        # the ranges 18 s early (18 s subtracted), one navigation 50 ms late (0.05 s added)
        session = apply_corrections(session, {"ranges": 18.0, f"nav.{late}": -0.05})
        print(
            f"{hours:g} h x {int(platforms)}: {len(session.ranges)} ranges, simulated in "
            f"{time.perf_counter() - made:.1f} s"
        )
        estimate_clock(session)  # warm-up
        times = []
        for _ in range(args.repeat):
            since = time.perf_counter()
            report = estimate_clock(session)
            times.append(time.perf_counter() - since)
        times.sort()
        print(f"  estimate_clock: {times[len(times) // 2]:.2f} s (median of {len(times)})")
        navs = [o for o in report.offsets if o.key.startswith("nav.")]
        worst = max(
            abs((o.offset_s or 0.0) - (18.05 if o.platform == late else 18.0)) for o in navs
        )
        print(
            f"  {late}: {next(o.offset_s for o in navs if o.platform == late):+.4f} s "
            f"(truth +18.050), largest error of the {len(navs)} navigation offsets "
            f"{worst * 1e3:.1f} ms; corrections {report.corrections}"
        )


if __name__ == "__main__":
    main()
