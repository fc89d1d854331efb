"""Scenario simulator with known truth: sessions for tests, benchmarks and the sample logs.

``simulate("paper-experiment", seed=0)`` returns a :class:`Simulation` whose ``session``
is an in-memory :class:`~coopproc.model.Session` (what the readers would return) and whose
``truth`` holds the true trajectories, distances, NLOS events and dead-reckoning errors;
:func:`write_simulation` writes both through the project's writers.
"""

from coopproc.sim.engine import scenario_params, simulate
from coopproc.sim.params import NavGapSpec, NlosSpec, OutageSpec, SimParams
from coopproc.sim.scenarios import SCENARIOS, Scenario
from coopproc.sim.truth import Simulation, Truth
from coopproc.sim.writer import write_simulation, write_truth

__all__ = [
    "SCENARIOS",
    "NavGapSpec",
    "NlosSpec",
    "OutageSpec",
    "Scenario",
    "SimParams",
    "Simulation",
    "Truth",
    "scenario_params",
    "simulate",
    "write_simulation",
    "write_truth",
]
