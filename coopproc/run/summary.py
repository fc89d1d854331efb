"""The few closing lines of ``coopproc run``: what was found and the headline numbers.

The same facts go into run.json (``summary``), so what the terminal printed is on record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from coopproc.report.change import change_of
from coopproc.report.consistency import consistency_lines
from coopproc.report.outlier_scores import FUSION_PREFIX
from coopproc.run.chain import PipelineParams
from coopproc.run.implausible import implausible_line
from coopproc.run.pipeline_output import PipelineOutput
from coopproc.stages.registry import method_label, nlos_source, primary_method

__all__ = ["RunSummary", "fusion_outliers", "summarize"]


@dataclass(frozen=True)
class RunSummary:
    lines: tuple[str, ...]
    facts: dict[str, Any] = field(default_factory=dict)


#: Decimals of the values in metres the summary prints.
_DECIMALS_M = 3


def _change(new: float, old: float) -> str:
    """The change from ``old`` to ``new`` (magnitudes in m) by the report tables' rule
    (:mod:`coopproc.report.change`): percent of ``old``, or the absolute change in m when
    ``|old|`` is near zero (under 0.010 m at the printed 3 decimals); "no change" when it
    rounds to zero at the printed digits (no "+0.0%" / "-0.0%")."""
    change = change_of(new, old, unit="m", decimals=_DECIMALS_M, signed=False)
    if change is None:
        return "n/a"
    return "no change" if float(change.number) == 0.0 else change.text()


def _count(n: int, noun: str) -> str:
    """``1 event``, ``2 events``, ``0 events``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _events_header(name: str, n_events: int, with_events: int, n_pairs: int) -> str:
    """``NLOS events (DI-Based): 4 on 2 of 3 pairs`` (pairs with events of all pairs)."""
    if n_events == 0:
        where = f"none on {_count(n_pairs, 'pair')}"
    elif with_events == n_pairs:
        where = f"{n_events} on {'all ' if n_pairs > 1 else ''}{_count(n_pairs, 'pair')}"
    else:
        where = f"{n_events} on {with_events} of {_count(n_pairs, 'pair')}"
    return f"NLOS events ({name}): {where}"


def _lookup(table: pd.DataFrame, key: str, value: str, method: str, column: str) -> float:
    rows = table[(table[key] == value) & (table["method"] == method)]
    return float(rows[column].iloc[0]) if len(rows) else math.nan


#: A pair whose NLOS detection ran on the ranges alone (ranging/local.py: ranges-only
#: calibration windows) for more than this share of its epochs is named in one line.
DEGRADED_FRACTION = 0.10


def _degraded(output: PipelineOutput, method: str) -> dict[str, float]:
    """pair -> share of its epochs in ranges-only windows, where above DEGRADED_FRACTION."""
    out = {}
    for (pair, m), cal in sorted(output.ranging_calibration.items()):
        fraction = float(cal.ranges_only_fraction)
        if m == method and fraction > DEGRADED_FRACTION:
            out[pair] = fraction
    return out


#: A platform's fused mean error this much (m) above its own navigation's, and 10 % more,
#: is reported as worse than its navigation.
WORSE_MIN_M = 0.02


def _primary(methods: tuple[str, ...]) -> str | None:
    """The method the headline compares with observed: the one a range processor declares
    primary (DI) if the run has it, else the last processed one."""
    return primary_method(m for m in methods if m != "observed")


def summarize(output: PipelineOutput) -> RunSummary:
    """Headline numbers: NLOS events per pair, RMSE and mean position error vs observed."""
    result = output.result
    default = ("observed", *PipelineParams().ranges)  # an output without its methods
    methods = output.methods or {"ranges": default, "positions": ()}
    range_methods = tuple(methods["ranges"])
    processed = [m for m in range_methods if m != "observed"]
    detector = nlos_source(output.nlos_methods)
    events = result.nlos_events
    det_events = events[events["method"] == detector]
    lines = []
    facts: dict[str, Any] = {"pairs": {}, "platforms": {}}
    pairs = sorted(result.ranges["pair"].unique())
    if detector is None:
        lines.append(
            "NLOS events: none (no NLOS-detecting method in the chain), "
            + _count(len(pairs), "pair")
        )
    else:
        with_events = len({str(p) for p in det_events["pair"].unique()} & {str(p) for p in pairs})
        name = method_label(detector, long=True)
        lines.append(_events_header(name, len(det_events), with_events, len(pairs)))
        degraded = _degraded(output, detector)
        if degraded:
            facts["nlos_degraded"] = degraded
            listed = ", ".join(f"{p} {100.0 * f:.0f} %" for p, f in degraded.items())
            lines.append(
                f"NLOS detection degraded (DI too poor to smooth: from the ranges alone) on "
                f"{len(degraded)} of {_count(len(pairs), 'pair')} for more than "
                f"{100.0 * DEGRADED_FRACTION:.0f} % of their time: {listed}"
            )
    for pair in pairs:
        n_events = int((det_events["pair"] == pair).sum())
        rmse = {m: _lookup(result.metrics, "pair", pair, m, "rmse") for m in range_methods}
        facts["pairs"][pair] = {"nlos_events": n_events} | {f"rmse_{m}": v for m, v in rmse.items()}
        obs = rmse.get("observed", math.nan)
        if math.isfinite(obs):
            shown = [m for m in processed if math.isfinite(rmse[m])]
            parts = [f"range RMSE observed {obs:.3f} m"] + [
                f"{method_label(m)} {rmse[m]:.3f} m ({_change(rmse[m], obs)})" for m in shown
            ]
            if processed and not shown:  # e.g. a tag's pair: no dead reckoning at one end
                parts.append("not processed (no dead reckoning at one end)")
            lines.append(f"  {pair}: {_count(n_events, 'event')}, " + ", ".join(parts))
        else:
            lines.append(
                f"  {pair}: {_count(n_events, 'event')} (no reference: no error statistics)"
            )
    outliers = fusion_outliers(
        result.range_weights, output.fusion_outlier_scores, tuple(methods.get("positions", ()))
    )
    if outliers:
        facts["fusion_outliers"] = outliers
        lines.append(_outlier_line(outliers))
    # an overconfident filter (NIS / NEES above the 95 % bound too often: report/consistency.py)
    lines += consistency_lines(result.range_weights, getattr(result, "states", None))
    pm = result.position_metrics
    primary = _primary(tuple(methods["positions"]))
    worse: list[str] = []
    for platform in sorted(pm["platform"].unique()):
        nav = _lookup(pm, "platform", platform, "nav", "mean")
        obs = _lookup(pm, "platform", platform, "observed", "mean")
        facts["platforms"][platform] = {"mean_nav": nav, "mean_observed": obs}
        text = f"  {platform}: mean horizontal error own nav {nav:.3f} m"
        base, second = obs, primary
        if math.isfinite(obs):
            text += f", fused observed {obs:.3f} m"
        elif not math.isfinite(nav):  # a tag: no navigation, not fused: raw fixes, smoothed
            base = _lookup(pm, "platform", platform, "lsq", "mean")
            text = f"  {platform} (tag): mean horizontal error lsq {base:.3f} m"
            smoothers = ("lsq_rts", "lsq_kf", "range_rts", "range_kf")
            smoothed = [m for m in methods["positions"] if m in smoothers]
            second = smoothed[0] if smoothed else None
        value = math.nan
        if second is not None:
            value = _lookup(pm, "platform", platform, second, "mean")
            facts["platforms"][platform][f"mean_{second}"] = value
            named = second == "observed" or method_label(second) != second
            label = f"fused {method_label(second)}" if named else second
            text += f", {label} {value:.3f} m ({_change(value, base)})"
        # platforms without a reference have no error statistics: no line
        if math.isfinite(base) or ("observed" not in methods["positions"] and math.isfinite(value)):
            lines.append(text)
        fused = [v for v in (obs, value) if math.isfinite(v)]
        if fused and math.isfinite(nav) and min(fused) > nav + max(0.1 * nav, WORSE_MIN_M):
            worse.append(platform)
    implausible = getattr(output, "implausible", None)  # an older output: none
    if implausible:
        facts["implausible"] = dict(implausible)
        lines.append(implausible_line(implausible))
    if worse:
        facts["worse_than_nav"] = worse
        lines.append(
            f"warning: the fused positions of {', '.join(worse)} are worse than their own "
            "navigation: the ranges may be biased (`coopproc report OUT --stochastic` gives "
            "each pair's bias against the reference) or the navigation better than its "
            "declared drift_sigma"
        )
    return RunSummary(lines=tuple(lines), facts=facts)


def fusion_outliers(
    weights: pd.DataFrame | None, scores: pd.DataFrame | None, order: tuple[str, ...] = ()
) -> dict[str, dict[str, Any]]:
    """Per fusion method (range_weights.csv's, in ``order``, then by name), the ranges it
    used, down-weighted (gamma < 1) and rejected, and from the ``fusion:<method>`` rows of
    nlos_scores.csv (``scores``: :func:`~coopproc.report.outlier_scores.fusion_outlier_scores`)
    those with a reference (``scored``), the outliers among them (> 3 sigma off the
    reference, ``outliers``), the down-weighted and the rejected outliers
    (``down_weighted_outliers``, the rows' tp; ``rejected_outliers``); run.json
    ``summary.fusion_outliers``."""
    if weights is None or not len(weights):
        return {}
    out: dict[str, dict[str, Any]] = {}
    method = weights["method"].astype(str).to_numpy()
    gamma = weights["gamma"].to_numpy(dtype=float)
    rejected = weights["rejected"].to_numpy()
    codes, uniques = pd.factorize(method)
    names = [str(n) for n in uniques]
    down = np.bincount(codes, weights=(gamma < 1.0).astype(float), minlength=len(names))
    rej = np.bincount(codes, weights=(rejected == 1).astype(float), minlength=len(names))
    total = np.bincount(codes, minlength=len(names))
    rank = {m: i for i, m in enumerate(order)}
    for k in sorted(range(len(names)), key=lambda k: (rank.get(names[k], len(rank)), names[k])):
        name = names[k]
        facts: dict[str, Any] = {
            "ranges": int(total[k]),
            "down_weighted": int(down[k]),
            "rejected": int(rej[k]),
        }
        if scores is not None and len(scores):
            mine = scores[scores["method"] == FUSION_PREFIX + str(name)]
            facts |= {
                "scored": int(mine["epochs"].sum()),
                "outliers": int(mine["nlos_true"].sum()),
                "down_weighted_outliers": int(mine["tp"].sum()),
                "rejected_outliers": int(mine["rejected_tp"].sum()),
            }
        out[str(name)] = facts
    return out


def _outlier_line(outliers: dict[str, dict[str, Any]]) -> str:
    """One line: ``fusion down-weighted 12 of 1764 ranges (2 rejected) in observed, 10 (2)
    of the 66 > 3 sigma off the reference; RN 3 (0), 3 (0) of 18; DI 0 (0), 0 (0) of 0
    (range_weights.csv)``: the first method in words, the others in the same order."""
    parts = []
    for k, (method, f) in enumerate(outliers.items()):
        name = method_label(method)
        scored = "scored" in f and f["scored"] > 0
        if k == 0:
            text = (
                f"fusion down-weighted {f['down_weighted']} of {_count(f['ranges'], 'range')} "
                f"({f['rejected']} rejected) in {name}"
            )
            if scored:
                text += (
                    f", {f['down_weighted_outliers']} ({f['rejected_outliers']}) of the "
                    f"{f['outliers']} > 3 sigma off the reference"
                )
        else:
            text = f"{name} {f['down_weighted']} ({f['rejected']})"
            if scored:
                text += (
                    f", {f['down_weighted_outliers']} ({f['rejected_outliers']}) of {f['outliers']}"
                )
        parts.append(text)
    return "; ".join(parts) + " (range_weights.csv)"
