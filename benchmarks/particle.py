"""Steps per second of the AACOPF and the standard PF (paper 004), side by side.

    python benchmarks/particle.py [--sizes 400 100] [--steps 20]

Builds a synthetic single-auxiliary input (target on a loop, one moving auxiliary,
1 Hz ranges), runs each filter for ``--steps`` epochs after a warm-up (numba compile),
and prints steps/s. Target (issue 7): >= 5 AACOPF steps/s at 400 x 400.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from coopproc.model import Trajectory
from coopproc.stages.particle.aacopf import run_aacopf
from coopproc.stages.particle.increments import dr_increments
from coopproc.stages.particle.inputs import LocateInputs
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.pf import run_pf


def synthetic_inputs(steps: int, seed: int = 0) -> LocateInputs:
    """A target on a 30 x 20 m loop and one moving auxiliary, ``steps`` + 1 epochs at 1 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(steps + 1, dtype=np.float64)
    w = 2 * np.pi / 90.0
    truth = np.column_stack([15 * np.sin(w * t), 10 * (1 - np.cos(w * t)), np.zeros_like(t)])
    aux = np.column_stack([20 - 12 * np.cos(2 * np.pi * t / 60), 15 + 0.15 * t])
    rng_m = np.hypot(*(truth[:, :2] - aux).T) + rng.normal(0, 0.1, t.shape)
    return LocateInputs(
        target="T",
        aux=("A1",),
        time_s=t,
        increments=dr_increments(Trajectory("T", t, truth), t),
        range_m=rng_m[:, None],
        sigma_m=np.full((t.shape[0], 1), 0.1),
        aux_en_m=aux[:, None, :],
    )


def steps_per_s(run: str, size: int, steps: int) -> float:
    params = LocateParams(N=size, M=size, snapshots=0)
    inputs = synthetic_inputs(steps)
    start = time.perf_counter()
    if run == "aacopf":
        run_aacopf(inputs, params, 0)
    else:
        run_pf(inputs, params, 0)
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[400, 100])
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    run_aacopf(synthetic_inputs(3), LocateParams(N=10, M=10, snapshots=0), 0)  # compile
    print(f"{'N x M':>10} {'particles':>10} {'AACOPF steps/s':>15} {'PF steps/s':>11}")
    for size in args.sizes:
        aco = steps_per_s("aacopf", size, args.steps)
        pf = steps_per_s("pf", size, args.steps)
        print(f"{size:>4} x {size:<4} {size * size:>10} {aco:>15.1f} {pf:>11.1f}")


if __name__ == "__main__":
    main()
