"""Steps per second of the AACOPF and the standard PF (paper 004), and ``locate`` whole.

The inputs are what ``coopproc locate`` gathers (``gather_inputs``) from the simulator's
``single-auxiliary`` scenario (seed 0: target T with dead reckoning in its own frame, a
moving GNSS auxiliary A1, 1 Hz ranges). Timed, each the median of ``--repeat`` runs after
a warm-up run of the same size (numba compiled or loaded):

- each filter alone on ``--steps`` epochs, at each ``--sizes`` N x M, in steps/s;
- ``locate()`` as the command calls it (AACOPF, PF and EKF with the default parameters,
  observability analysis and tables) on a ``--locate-seconds`` session.

Target (issue 7): >= 5 AACOPF steps/s at 400 x 400.

    python benchmarks/particle.py [--sizes 400 100] [--steps 20] [--locate-seconds 60]
"""

from __future__ import annotations

import argparse

from _common import load, median_seconds, spread, target

from coopproc.sim import simulate
from coopproc.stages.particle.aacopf import run_aacopf
from coopproc.stages.particle.inputs import LocateInputs, gather_inputs
from coopproc.stages.particle.locate import locate
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.pf import run_pf


def inputs_for(seconds: float) -> tuple[object, LocateInputs]:
    """The simulated session of ``seconds`` and locate's inputs for T with A1."""
    session = simulate("single-auxiliary", seed=0, duration_s=seconds).session
    return session, gather_inputs(session, "T", ("A1",))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[400, 100])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--locate-seconds", type=float, default=60.0)
    args = parser.parse_args()

    _, inputs = inputs_for(float(args.steps))
    steps = inputs.n_epochs - 1
    print(f"single-auxiliary: {steps} steps per run ({load()})")
    print(f"{'N x M':>10} {'particles':>10} {'AACOPF steps/s':>15} {'PF steps/s':>11}")
    rates: dict[int, float] = {}
    for size in args.sizes:
        params = LocateParams(N=size, M=size, snapshots=0)
        aco, aco_t = median_seconds(lambda p=params: run_aacopf(inputs, p, 0), args.repeat)
        pf, pf_t = median_seconds(lambda p=params: run_pf(inputs, p, 0), args.repeat)
        rates[size] = steps / aco
        print(
            f"{size:>4} x {size:<4} {size * size:>10} {steps / aco:>15.1f} {steps / pf:>11.1f}"
            f"   (AACOPF {spread(aco_t)}; PF {spread(pf_t)})"
        )
    session, _ = inputs_for(args.locate_seconds)
    params = LocateParams()
    whole, times = median_seconds(lambda: locate(session, "T", ("A1",), params), args.repeat)
    print(
        f"locate() {params.N} x {params.M}, {', '.join(params.methods)}, "
        f"{args.locate_seconds:g} s session: {whole:.2f} s  ({spread(times)}; {load()})"
    )
    if 400 in rates:
        print(target("AACOPF >= 5 steps/s at 400 x 400", rates[400], 5.0, at_most=False))
    else:
        print("target AACOPF >= 5 steps/s at 400 x 400: not run (add 400 to --sizes)")


if __name__ == "__main__":
    main()
