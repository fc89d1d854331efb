"""The few closing lines of ``coopproc run``: what was found and the headline numbers.

The same facts go into run.json (``summary``), so what the terminal printed is on record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from coopproc.run.pipeline import PipelineOutput

__all__ = ["RunSummary", "summarize"]


@dataclass(frozen=True)
class RunSummary:
    lines: tuple[str, ...]
    facts: dict[str, Any] = field(default_factory=dict)


def _change(new: float, old: float) -> str:
    if not (math.isfinite(new) and math.isfinite(old)) or old == 0:
        return "n/a"
    return f"{100.0 * (new - old) / old:+.1f}%"


def _lookup(table: pd.DataFrame, key: str, value: str, method: str, column: str) -> float:
    rows = table[(table[key] == value) & (table["method"] == method)]
    return float(rows[column].iloc[0]) if len(rows) else math.nan


def summarize(output: PipelineOutput) -> RunSummary:
    """Headline numbers: NLOS events per pair, RMSE and mean position error vs observed."""
    result = output.result
    events = result.nlos_events
    di_events = events[events["method"] == "di"]
    lines = []
    facts: dict[str, Any] = {"pairs": {}, "platforms": {}}
    pairs = sorted(result.ranges["pair"].unique())
    lines.append(f"NLOS events (DI-Based): {len(di_events)} on {len(pairs)} pairs")
    for pair in pairs:
        n_events = int((di_events["pair"] == pair).sum())
        obs = _lookup(result.metrics, "pair", pair, "observed", "rmse")
        di = _lookup(result.metrics, "pair", pair, "di", "rmse")
        rn = _lookup(result.metrics, "pair", pair, "rn", "rmse")
        facts["pairs"][pair] = {
            "nlos_events": n_events,
            "rmse_observed": obs,
            "rmse_rn": rn,
            "rmse_di": di,
        }
        if math.isfinite(obs):
            lines.append(
                f"  {pair}: {n_events} events, range RMSE observed {obs:.3f} m, "
                f"RN {rn:.3f} m ({_change(rn, obs)}), DI {di:.3f} m ({_change(di, obs)})"
            )
        else:
            lines.append(f"  {pair}: {n_events} events (no reference: no error statistics)")
    pm = result.position_metrics
    for platform in sorted(pm["platform"].unique()):
        obs = _lookup(pm, "platform", platform, "observed", "mean")
        di = _lookup(pm, "platform", platform, "di", "mean")
        nav = _lookup(pm, "platform", platform, "nav", "mean")
        facts["platforms"][platform] = {"mean_nav": nav, "mean_observed": obs, "mean_di": di}
        if math.isfinite(obs):
            lines.append(
                f"  {platform}: mean horizontal error own nav {nav:.3f} m, fused observed "
                f"{obs:.3f} m, fused DI {di:.3f} m ({_change(di, obs)})"
            )
    return RunSummary(lines=tuple(lines), facts=facts)
