"""IMU epochs per second of the INS engine (issue 12 item 7): the compiled forward filter,
the RTS smoother over the full error state, and the plain numpy/Python loop.

The run is :func:`coopproc.ins.scenario.aided_scenario`: ``--hours`` of a level 10 m
circle at 2 m/s with ``--rate`` Hz IMU samples of the industrial grade (turn-on biases,
white noise), UWB ranges at 10 Hz to 4 anchors (sigma 5 cm, lever arm 0.8 m, IGG-III),
odometer speed at 10 Hz and NHC at 10 Hz; the covariance is propagated every 10 samples.
Timed, each the median of ``--repeat`` runs after a warm-up run (numba compiled or loaded
from its cache), the inputs prepared once (alignment and the aiding tied to the samples,
:func:`coopproc.ins.engine.prepare`):

- forward: :func:`coopproc.ins.engine.run_forward` (compiled);
- smoother: :func:`coopproc.ins.smoother.smooth` on that forward run (backward pass and
  the smoothed nav of every IMU sample);
- plain: the same forward loop in numpy/Python (:func:`coopproc.ins.loop.run_events`),
  on the first ``--plain-seconds`` of the same kind of run only (it is ~100x slower),
  reported in epochs/s of that span.

Each rate is also given per CPU second of this process (the machine is shared).

Targets (issue 12): forward >= 200,000 IMU epochs/s, the smoother at least as fast.

    python benchmarks/ins.py [--hours 1] [--rate 200] [--repeat 3] [--plain-seconds 60]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np
from _common import load, median_seconds, spread, target

from coopproc.frames import geodetic2enu
from coopproc.ins.engine import InsAiding, InsConfig, Prepared, prepare, run_forward
from coopproc.ins.models import GRADES
from coopproc.ins.scenario import aided_scenario
from coopproc.ins.smoother import smooth


def prepared(seconds: float, rate_hz: float) -> tuple[Prepared, object]:
    """The prepared aided run of ``seconds`` and its scenario (for the accuracy line)."""
    fig = GRADES["industrial"]
    sc = aided_scenario("circle", fig, seconds, seed=0, rate_hz=rate_hz)
    aid = InsAiding(ranges=sc.aiding.ranges, speed=sc.aiding.speed, nhc=True, robust=(3.0, 4.5))
    cfg = InsConfig(fig, sc.origin_llh, sc.alignment, start_enu=np.zeros(3),
                    start_vel_enu=sc.truth_vel[0])  # fmt: skip
    return prepare(sc.imu, aid, cfg), sc


def cpu_rate(fn: Callable[[], object], epochs: int, repeat: int) -> float:
    """IMU epochs per CPU second of this process (median of ``repeat`` runs; the machine
    is shared, so the wall figure moves with the load and this one much less)."""
    cpu = []
    for _ in range(max(repeat, 1)):
        start = time.process_time()
        fn()
        cpu.append(time.process_time() - start)
    return epochs / statistics.median(cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--rate", type=float, default=200.0)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--plain-seconds", type=float, default=60.0)
    args = parser.parse_args()

    start = time.perf_counter()
    prep, sc = prepared(args.hours * 3600.0, args.rate)
    k_n = prep.time_s.size
    fig = prep.ekf.noise
    print(
        f"ins: {args.hours:g} h of {args.rate:g} Hz IMU ({k_n} epochs), UWB 10 Hz to 4 "
        f"anchors, odometer 10 Hz, NHC 10 Hz, industrial grade, 15 states "
        f"(built in {time.perf_counter() - start:.1f} s; {load()})"
    )
    fwd, fwd_t = median_seconds(lambda: run_forward(prep), args.repeat)
    run = run_forward(prep)
    sm, sm_t = median_seconds(lambda: smooth(prep.time_s, run, fig), args.repeat)
    fwd_cpu = cpu_rate(lambda: run_forward(prep), k_n, args.repeat)
    sm_cpu = cpu_rate(lambda: smooth(prep.time_s, run, fig), k_n, args.repeat)
    stored = run.p_filt.nbytes + run.x_filt.nbytes + run.epoch_in.nbytes + run.epoch_k.nbytes
    print(
        f"forward (compiled): {k_n / fwd:>10,.0f} IMU epochs/s  ({spread(fwd_t)}; {load()}; "
        f"per CPU second {fwd_cpu:,.0f})"
    )
    print(
        f"smoother (RTS):     {k_n / sm:>10,.0f} IMU epochs/s  ({spread(sm_t)}; {load()}; "
        f"per CPU second {sm_cpu:,.0f})"
    )
    print(
        f"stored for the smoother: {run.epoch_k.size} propagation epochs, "
        f"{stored / 1e6:.0f} MB (P, x, Phi inputs, float64)"
    )
    short, _ = prepared(args.plain_seconds, args.rate)
    pl, pl_t = median_seconds(lambda: run_forward(short, "plain"), args.repeat)
    plain_rate = short.time_s.size / pl
    pl_cpu = cpu_rate(lambda: run_forward(short, "plain"), short.time_s.size, 1)
    print(
        f"plain numpy/Python: {plain_rate:>10,.0f} IMU epochs/s  (first {args.plain_seconds:g} s, "
        f"{short.time_s.size} epochs; {spread(pl_t)}; {load()}; per CPU second "
        f"{pl_cpu:,.0f}); compiled / plain x {k_n / fwd / plain_rate:.0f} "
        f"(per CPU second x {fwd_cpu / pl_cpu:.0f})"
    )
    s = smooth(prep.time_s, run, fig)
    truth = sc.truth_enu  # type: ignore[attr-defined]
    late = prep.time_s > 10.0
    rms = []
    for nav in (run.nav, s.nav):
        llh = np.column_stack([np.degrees(nav[:, 0]), np.degrees(nav[:, 1]), nav[:, 2]])
        err = (geodetic2enu(llh, prep.origin_llh) - truth)[late, :2]
        rms.append(float(np.sqrt(np.mean(np.sum(err**2, axis=1)))))
    print(f"(accuracy check: horizontal RMS forward {rms[0]:.3f} m, smoothed {rms[1]:.3f} m)")
    print(target("forward >= 200,000 IMU epochs/s", k_n / fwd, 200_000.0, at_most=False))
    print(target("smoother >= forward", k_n / sm, k_n / fwd, at_most=False))


if __name__ == "__main__":
    main()
