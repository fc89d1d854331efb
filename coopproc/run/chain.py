"""The stage chain of a run: ``[pipeline]`` of the run config, resolved into ordered steps.

``[pipeline] ranges`` names range methods (each made by one range processor of
:mod:`coopproc.stages.registry`), ``[pipeline] positions`` names position estimators, each
run on every range set (the observed ranges and each processed method's). Every step
declares what it needs and gives, as named artifacts:

- ``ranges:<set>``: a range set (``ranges:observed`` is there from the start);
- ``cp``: the cooperative solution with the observed ranges (the CP DI of paper 000);
- ``positions:<method>``: one positions.csv method.

:func:`resolve` orders the steps so that every input exists before it is used (in the
order they are listed when several are ready), and adds the cooperative fusion of the
observed ranges when a range processor needs ``cp`` and no listed estimator gives it.
The default reproduces paper 000's chain: fusion (observed) -> ranging (rn, di) ->
fusion (rn) -> fusion (di).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from coopproc.configtools import nearest
from coopproc.errors import ConfigError
from coopproc.stages.base import RESERVED_NAMES
from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES, range_stage_of

__all__ = ["PipelineParams", "Step", "chain_lines", "resolve"]


def _range_methods() -> list[str]:
    return [m for stage in RANGE_STAGES.values() for m in stage.methods]


@dataclass(frozen=True)
class PipelineParams:
    """``[pipeline]``: which methods the run produces."""

    ranges: tuple[str, ...] = field(
        default=("rn", "di"),
        metadata={
            "help": "range methods after the observed ranges, in ranges.csv column order; "
            "[] = none (available: " + ", ".join(_range_methods()) + ")"
        },
    )
    positions: tuple[str, ...] = field(
        default=("fusion",),
        metadata={
            "help": "position estimators, each run on every range set; [] = none "
            "(available: " + ", ".join(POSITION_STAGES) + ")"
        },
    )
    observed_only: tuple[str, ...] = field(
        default=(),
        metadata={
            "help": "position estimators of `positions` run on the observed ranges only "
            "(the anchors' comparison rows: lsq, lsq_rts)"
        },
    )
    anchor_methods: bool = field(
        default=True,
        metadata={
            "help": "a session with anchors: lsq and lsq_rts also position every platform "
            "with navigation that ranges to them (comparison rows); false: not"
        },
    )

    def __post_init__(self) -> None:
        valid = _range_methods()
        for method in self.ranges:
            if method not in valid:
                raise ValueError(f"unknown range method '{method}'{nearest(method, valid)}")
        for name in self.positions:
            if name not in POSITION_STAGES:
                raise ValueError(
                    f"unknown position estimator '{name}'{nearest(name, POSITION_STAGES)}"
                )
        for name in self.observed_only:
            if name not in POSITION_STAGES:
                raise ValueError(
                    f"observed_only: unknown position estimator '{name}'"
                    f"{nearest(name, POSITION_STAGES)}"
                )
        for what, names in (("ranges", self.ranges), ("positions", self.positions)):
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise ValueError(f"{what}: '{twice[0]}' is listed twice")


@dataclass(frozen=True)
class Step:
    """One stage run of the chain."""

    kind: Literal["ranges", "positions"]
    stage: str
    #: the methods it produces: range methods, or the one positions.csv method
    methods: tuple[str, ...]
    #: the range set a position estimator works on (None for a range processor)
    range_set: str | None
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    #: why the step is there when the config did not ask for it ("" if it did)
    reason: str = ""

    @property
    def label(self) -> str:
        """How progress, timings and ``coopproc config`` name the step."""
        what = ", ".join(self.methods) if self.kind == "ranges" else self.range_set
        return f"{self.stage} ({what})"


def _range_steps(params: PipelineParams) -> list[Step]:
    steps = []
    seen: list[str] = []
    for method in params.ranges:
        stage = range_stage_of(method)
        assert stage is not None  # PipelineParams checked the names
        if stage.name in seen:
            continue
        seen.append(stage.name)
        methods = tuple(m for m in params.ranges if m in stage.methods)
        inputs = ("ranges:observed", "cp") if stage.needs_cp else ("ranges:observed",)
        steps.append(
            Step("ranges", stage.name, methods, None, inputs, tuple(f"ranges:{m}" for m in methods))
        )
    return steps


def _position_step(name: str, range_set: str, gives_cp: bool, reason: str = "") -> Step:
    stage = POSITION_STAGES[name]
    method = stage.method(range_set)
    inputs: tuple[str, ...] = (f"ranges:{range_set}",)
    if stage.needs_observed and range_set != "observed":
        inputs += (f"positions:{stage.method('observed')}",)
    outputs: tuple[str, ...] = (f"positions:{method}",) + (("cp",) if gives_cp else ())
    return Step("positions", name, (method,), range_set, inputs, outputs, reason)


def resolve(params: PipelineParams) -> tuple[Step, ...]:
    """The steps of the chain, in run order (module docstring)."""
    range_steps = _range_steps(params)
    needs_cp = [s.stage for s in range_steps if "cp" in s.inputs]
    provider = next(
        (n for n in params.positions if needs_cp and POSITION_STAGES[n].provides_cp), None
    )
    position_steps = []
    if needs_cp and provider is None:
        provider = next(n for n, s in POSITION_STAGES.items() if s.provides_cp)
        reason = f"the cooperative solution that {needs_cp[0]} needs"
        position_steps.append(_position_step(provider, "observed", True, reason))
    for name in params.positions:
        for range_set in ("observed", *params.ranges):
            only = POSITION_STAGES[name].observed_only or name in params.observed_only
            if only and range_set != "observed":
                continue
            gives_cp = name == provider and range_set == "observed"
            position_steps.append(_position_step(name, range_set, gives_cp))

    produced = [m for s in position_steps for m in s.methods]
    for method in produced:
        if produced.count(method) > 1 or method in RESERVED_NAMES - {"observed"}:
            raise ConfigError(f"[pipeline]: two steps would both write positions method '{method}'")
    return _ordered([*range_steps, *position_steps])


def _ordered(steps: list[Step]) -> tuple[Step, ...]:
    available = {"ranges:observed"}
    pending = list(steps)
    order: list[Step] = []
    while pending:
        ready = next((s for s in pending if set(s.inputs) <= available), None)
        if ready is None:
            stuck = pending[0]
            missing = sorted(set(stuck.inputs) - available)
            raise ConfigError(
                f"[pipeline]: {stuck.label} needs {', '.join(missing)}, which no step gives"
            )
        pending.remove(ready)
        order.append(ready)
        available.update(ready.outputs)
    return tuple(order)


def chain_lines(steps: tuple[Step, ...]) -> list[str]:
    """The chain, one numbered line per step (``coopproc config``, docs)."""
    width = max((len(s.label) for s in steps), default=0)
    lines = []
    for k, s in enumerate(steps, start=1):
        line = f"{k}. {s.label:<{width}}  {', '.join(s.inputs)} -> {', '.join(s.outputs)}"
        lines.append(line + (f"  ({s.reason})" if s.reason else ""))
    return lines
