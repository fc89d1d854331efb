"""What a ``coopproc run`` did, checked against the simulator's truth (issue 35, part 1).

A benchmark's time and memory are only comparable with a target when the run did the
work the default chain promises on that session. Before issue 35 `scale.py` printed
"target met" for a day on which the ranging stage passed all 45 pairs through and found
0 of 500 simulated NLOS events (the ``rn`` and ``di`` fusions reused, never run); with
the work done the same day took four times as long. This module reads a run's output
directory and the simulated session's ``truth/`` and says:

- per method (DI, RN) how many pairs ran in each mode: **smoothing** (every calibration
  window smoothed with the DI), **ranges-only** (some windows, not all, leaned on the
  ranges alone) and **passed through** (every window ranges-only: run.json
  ``calibration.ranging.<pair>.<method>.passthrough``); from run.json, whose
  ``ranges_only_fraction`` nlos_scores.csv repeats;
- the NLOS events found against ``truth/nlos_events.csv``: true events some event of the
  method overlaps (``found``, :func:`overlaps`, shared with ``nlos_length.py``), the
  simulated events (``true``) and events overlapping none (``false``);
- which of the ``rn`` and ``di`` fusions ran and which were reused: the fusion stage
  notes "fusion (<set>): ... reused, not run again" when a range set holds the observed
  ranges (coopproc/stages/fusion/entry.py ``_same_as_observed``);
- per pair whether the simulated dead reckoning *can* smooth (:func:`smoothable_pairs`):
  the steady-state gain of the distance filter with the true DI error growth and the true
  UWB noise at or below ``passthrough_gain`` (the ranging stage's own decision rule,
  local.py, with the truth in place of the estimates).

:func:`verdict` turns that into ``None`` (the work is complete: a target may say
met/missed) or the reason it is not comparable; ``_common.target(..., incomplete=...)``
prints it.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "MIN_RECALL",
    "Work",
    "overlaps",
    "read_work",
    "smoothable_pairs",
    "verdict",
]

#: Event recall (DI-Based, the default chain's NLOS output) below which a run did not do
#: the work: issue 35's "recall >= 0.9 of the simulated events" (the figure issue 30's
#: nlos_length.py target uses on the `large` scenario at every length).
MIN_RECALL = 0.9
#: Seconds of slack either side when an event is matched to a true one (nlos_length.py's
#: matching since issue 30: one range epoch at the `large` scenario's 1 Hz).
MATCH_SLACK_S = 1.0
#: The calibration window of the ranging stage's decision (RangingConfig.nlos
#: calibration_window_s default): the truth-side gain is judged on the same windows.
WINDOW_S = 300.0
MODES = ("smoothing", "ranges-only", "passed through")


def overlaps(events: pd.DataFrame, truth: pd.DataFrame) -> tuple[int, int]:
    """(true events some detected event overlaps, detected events that overlap none).

    Both frames have ``pair``, ``start``, ``end`` (seconds); an event overlaps a true one
    when their spans, widened by :data:`MATCH_SLACK_S`, intersect."""
    events = events.reset_index(drop=True)
    found = 0
    used = np.zeros(len(events), dtype=bool)
    for pair, group in truth.groupby("pair"):
        mine = events[events["pair"] == pair]
        for start, end in group[["start", "end"]].to_numpy(float):
            hit = (mine["start"] <= end + MATCH_SLACK_S) & (mine["end"] >= start - MATCH_SLACK_S)
            if hit.any():
                found += 1
                used[np.flatnonzero(events.index.isin(mine.index[hit]))] = True
    return found, int(np.count_nonzero(~used))


@dataclass
class Work:
    """What one run did (one per run; the benchmarks print the first and check all)."""

    #: method -> mode (:data:`MODES`) -> pairs
    modes: dict[str, dict[str, int]] = field(default_factory=dict)
    #: method -> (found, true, false) NLOS events against the truth
    events: dict[str, tuple[int, int, int]] = field(default_factory=dict)
    #: fusion ("rn", "di") -> "run" | "reused" | "absent"
    fusions: dict[str, str] = field(default_factory=dict)
    #: pairs passed through (either method) whose simulated dead reckoning can smooth
    passed_smoothable: list[str] = field(default_factory=list)
    #: pairs whose simulated dead reckoning can smooth / all pairs with a truth
    smoothable: int = 0
    pairs: int = 0

    def recall(self, method: str = "di") -> float | None:
        found, true, _ = self.events.get(method, (0, 0, 0))
        return found / true if true else None

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def cells(self) -> str:
        """The table's work columns: DI and RN pairs smoothing/ranges-only/passed, DI and
        RN events found/true/false, the rn and di fusions run (R) or reused (u)."""
        out = ""
        for method in ("di", "rn"):
            m = self.modes.get(method, {})
            out += f"{'/'.join(str(m.get(k, 0)) for k in MODES):>10}"
        for method in ("di", "rn"):
            out += f"{'/'.join(str(v) for v in self.events.get(method, (0, 0, 0))):>12}"
        mark = {"run": "R", "reused": "u", "absent": "-"}
        out += f"{''.join(mark[self.fusions.get(k, 'absent')] for k in ('rn', 'di')):>6}"
        return out


WORK_HEAD = f"{'DI s/ro/p':>10}{'RN s/ro/p':>10}{'DI f/t/x':>12}{'RN f/t/x':>12}{'fus':>6}"
WORK_NOTE = (
    "(s/ro/p: pairs smoothing / ranges-only in some windows / passed through; f/t/x:\n"
    " NLOS events found / simulated / false; fus: rn and di fusions Run or reused (u))"
)


def _mode(facts: dict[str, Any]) -> str:
    if facts.get("passthrough"):
        return "passed through"
    return "ranges-only" if (facts.get("ranges_only_fraction") or 0.0) > 0.0 else "smoothing"


def _fusion(info: dict[str, Any], name: str) -> str:
    notes = [*info.get("calibration", {}).get("notes", []), *info.get("notes", [])]
    if any(n.startswith(f"fusion ({name}): ") and "reused" in n for n in notes):
        return "reused"
    return "run" if any(k == f"fusion ({name})" for k in info.get("timings_s", {})) else "absent"


def _sim_value(session: Path, name: str) -> float:
    """A SimParams field of the simulated session: truth/params.toml's, else the
    scenario's default (the simulator writes the fields that differ)."""
    params = tomllib.loads((session / "truth" / "params.toml").read_text())
    if name in params:
        return float(params[name])
    from coopproc.sim.engine import scenario_params

    return float(getattr(scenario_params(str(params.get("scenario", "large"))), name))


def default_passthrough_gain() -> float:
    """The ranging stage's default ``passthrough_gain`` (RangingConfig.nlos)."""
    from coopproc.stages.ranging.config import NLOSParams

    return float(NLOSParams().passthrough_gain)


def smoothable_pairs(session: Path, passthrough_gain: float | None = None) -> dict[str, bool]:
    """pair -> whether the simulated dead reckoning can smooth its ranges.

    The DI's error per range epoch is, to first order, the increment of the two platforms'
    relative DR error (truth/dr_error.csv, 1 Hz) along the line of sight (truth/traj_*).
    Its mean square over each :data:`WINDOW_S` window is the process variance q of the
    distance filter's random walk, the true UWB noise (SimParams ``uwb_noise_m``) its R;
    :func:`coopproc.stages.ranging.calibration.steady_gain` of the two is what local.py
    compares with ``passthrough_gain`` (None: the stage's default). A pair can smooth
    when its median window gain is at or below it. The mean square (not the variance)
    keeps a steady drift in q, as the data-side growth estimate ``L - cumsum(I)`` does."""
    from coopproc.stages.ranging.calibration import steady_gain

    if passthrough_gain is None:
        passthrough_gain = default_passthrough_gain()
    truth = session / "truth"
    err = pd.read_csv(truth / "dr_error.csv")
    r = _sim_value(session, "uwb_noise_m") ** 2
    grid = np.sort(err["time"].unique())
    pos: dict[str, np.ndarray] = {}
    e: dict[str, np.ndarray] = {}
    for name, g in err.groupby("platform"):
        g = g.set_index("time").reindex(grid)
        e[str(name)] = g[["error_east", "error_north"]].to_numpy(float)
        traj = pd.read_csv(truth / f"traj_{name}.csv", usecols=["time", "east", "north"])
        t = traj["time"].to_numpy(float)
        pos[str(name)] = np.column_stack(
            [np.interp(grid, t, traj[c].to_numpy(float)) for c in ("east", "north")]
        )
    pairs = pd.read_csv(truth / "distances.csv", usecols=["pair"])["pair"].unique()
    out: dict[str, bool] = {}
    windows = ((grid - grid[0]) // WINDOW_S).astype(int)[1:]
    for pair in pairs:
        a, b = str(pair).split("-")
        los = pos[b] - pos[a]
        los /= np.maximum(np.linalg.norm(los, axis=1, keepdims=True), 1e-9)
        rel = e[b] - e[a]
        step = np.sum(np.diff(rel, axis=0) * los[1:], axis=1)
        ok = np.isfinite(step)
        n = np.bincount(windows[ok])
        sq = np.bincount(windows[ok], weights=step[ok] ** 2, minlength=n.size)
        gains = [steady_gain(float(sq[w] / n[w]), r) for w in np.flatnonzero(n)]
        out[str(pair)] = bool(gains) and float(np.nanmedian(gains)) <= passthrough_gain
    return out


def read_work(out: Path, session: Path, smoothable: dict[str, bool] | None = None) -> Work:
    """The work record of the run in ``out`` on the simulated ``session``;
    ``smoothable``: :func:`smoothable_pairs` of the session, when already computed."""
    info = json.loads((out / "run.json").read_text())
    ranging = info.get("calibration", {}).get("ranging", {})
    work = Work(pairs=len(ranging))
    passed: set[str] = set()
    for method in ("di", "rn"):
        counts = dict.fromkeys(MODES, 0)
        for pair, facts in ranging.items():
            if method in facts:
                mode = _mode(facts[method])
                counts[mode] += 1
                if mode == "passed through":
                    passed.add(pair)
        work.modes[method] = counts
    truth = pd.read_csv(session / "truth" / "nlos_events.csv")
    events = pd.read_csv(out / "nlos_events.csv")
    for method in ("di", "rn"):
        found, false = overlaps(events[events["method"] == method], truth)
        work.events[method] = (found, len(truth), false)
    work.fusions = {name: _fusion(info, name) for name in ("rn", "di")}
    can = smoothable if smoothable is not None else smoothable_pairs(session)
    work.smoothable = sum(can.values())
    work.passed_smoothable = sorted(p for p in passed if can.get(p, False))
    return work


def verdict(work: Work) -> str | None:
    """None when the run did the full work of the default chain on its session, else why
    a time or memory figure of it is not comparable with a target."""
    reasons = []
    if work.passed_smoothable:
        n = len(work.passed_smoothable)
        reasons.append(
            f"{n} pair{'s' * (n != 1)} passed through whose dead reckoning can smooth "
            f"({', '.join(work.passed_smoothable[:3])}{', ...' if n > 3 else ''})"
        )
    found, true, _ = work.events.get("di", (0, 0, 0))
    if true == 0:
        reasons.append("no simulated NLOS event to find")
    elif found / true < MIN_RECALL:
        reasons.append(f"DI found {found} of {true} NLOS events (< {MIN_RECALL:.0%})")
    return "; ".join(reasons) or None
