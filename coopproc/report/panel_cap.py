"""The default cap on the panels a figure draws, and what it leaves out.

A run of 20 platforms has 190 pairs: eight pages of 24 panels per pair figure, most of the
figures' drawing time, and nobody reads them all. Unless ``--pairs`` / ``--platforms``
chose what to draw, each figure draws at most ``max_pages`` pages (``--max-pages``,
``[run] max_pages``, default :data:`~coopproc.report.style.MAX_PAGES`; 0: no cap) of
``max_panels`` panels. When a figure has more panels, it draws those most worth looking
at, in the usual order (by name, events in time order), ties by that order:

- a pair panel: the largest observed range RMSE (``metrics.csv``, method ``observed``);
- a platform panel: the largest horizontal position error (``position_metrics.csv``
  RMSE of the primary method, :func:`~coopproc.report.evaluation_plots.track_method`);
- an NLOS event panel: the largest NLOS estimate (absolute, any step or method).

Panels without a score come last. :class:`Capped` records what a figure left out; its
:meth:`Capped.note` tells the user how to draw the rest (``coopproc report OUT --plots
--pairs ...`` or ``--max-pages 0``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import pandas as pd

from coopproc.report.evaluation_plots import track_method
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels
from coopproc.report.run_tables import RunTables

__all__ = [
    "Capped",
    "cap_indices",
    "cap_panels",
    "event_score",
    "pair_scores",
    "platform_scores",
]

#: How a figure's panels are ranked, by the noun of its panels.
BASIS = {
    "pairs": "largest observed range RMSE",
    "platforms": "largest horizontal position error",
    "NLOS events": "largest NLOS estimates",
}
#: The option choosing the panels of each noun.
_OPTION = {"pairs": "--pairs", "platforms": "--platforms", "NLOS events": "--pairs"}
#: Most names given in a note's example command.
_EXAMPLE_NAMES = 3


def _scores(frame: pd.DataFrame | None, key: str, method: str | None) -> dict[str, float]:
    """``rmse`` per ``key`` of the rows of ``method`` (None or absent: the largest of any)."""
    if frame is None or not len(frame) or not {key, "rmse"} <= set(frame.columns):
        return {}
    rows = frame
    if method is not None and "method" in frame.columns:
        own = frame[frame["method"].astype(str) == method]
        rows = own if len(own) else frame
    rmse = pd.to_numeric(rows["rmse"], errors="coerce")
    best = rmse.groupby(rows[key].astype(str), sort=True).max()
    return {str(k): float(v) for k, v in best.items() if math.isfinite(v)}


def pair_scores(run: RunTables) -> dict[str, float]:
    """The observed range RMSE of each pair (``metrics.csv``)."""
    return _scores(run.metrics, "pair", "observed")


def platform_scores(run: RunTables) -> dict[str, float]:
    """The primary position method's horizontal RMSE of each platform."""
    return _scores(run.position_metrics, "platform", track_method(run))


def event_score(rows: pd.DataFrame) -> float:
    """The largest absolute NLOS estimate of one event panel's rows (NaN without one)."""
    if "estimate" not in rows.columns or not len(rows):
        return math.nan
    value = pd.to_numeric(rows["estimate"], errors="coerce").abs().max()
    return float(value) if pd.notna(value) else math.nan


def cap_indices(scores: Sequence[float], cap: int) -> list[int]:
    """The indices of the ``cap`` highest ``scores`` (NaN last, ties by index), ascending."""
    if cap <= 0 or len(scores) <= cap:
        return list(range(len(scores)))
    order = sorted(
        range(len(scores)),
        key=lambda i: (math.isnan(scores[i]), -scores[i] if not math.isnan(scores[i]) else 0, i),
    )
    return sorted(order[:cap])


def keyed_scores(keys: Sequence[str], scores: Mapping[str, float]) -> list[float]:
    """``scores`` of ``keys`` in order, NaN where a key has none."""
    return [scores.get(k, math.nan) for k in keys]


@dataclass(frozen=True)
class Capped:
    """What the cap left out of figure ``name``: ``drawn`` and ``left_out`` keys (pairs,
    platforms or event titles, per ``noun``) out of ``total``."""

    name: str
    noun: str
    drawn: tuple[str, ...]
    left_out: tuple[str, ...]
    pages: int
    max_panels: int

    @property
    def total(self) -> int:
        return len(self.drawn) + len(self.left_out)

    @property
    def basis(self) -> str:
        return BASIS.get(self.noun, "")

    def note(self) -> str:
        """One sentence: what was drawn, on what basis, and how to draw the others."""
        option = _OPTION.get(self.noun, "--pairs")
        if self.noun == "NLOS events":  # titles "A-B, event 2 (t = ...)": their pairs
            pool = list(dict.fromkeys(k.split(",", 1)[0] for k in self.left_out))
        else:
            pool = list(self.left_out)
        names = pool[:_EXAMPLE_NAMES]
        example = ",".join(names) + (",..." if len(pool) > len(names) else "")
        n = len(self.drawn)
        which = f"the {n} with the {self.basis}" if self.basis else f"the first {n}"
        pages = f"{self.pages} page{'s' if self.pages != 1 else ''}"
        panels = f"{self.max_panels} panel{'s' if self.max_panels != 1 else ''}"
        return (
            f"{self.name}: drew {n} of {self.total} {self.noun} ({which}; at most "
            f"{pages} of {panels}); draw "
            f"others with `coopproc report OUT --plots {option} {example}`, or all with "
            "`--max-pages 0`."
        )


def cap_panels(
    name: str, panels: Panels, run: RunTables, opts: FigureOptions
) -> tuple[Panels, Capped | None]:
    """``panels`` cut to ``opts.panel_cap`` (see the module docstring) and what was left
    out; unchanged (and None) when they fit."""
    cap = opts.panel_cap
    if cap is None or len(panels.keys) <= cap:
        return panels, None
    scores = panels.scores
    if scores is None and panels.noun == "pairs":
        scores = keyed_scores(panels.keys, pair_scores(run))
    elif scores is None and panels.noun == "platforms":
        scores = keyed_scores(panels.keys, platform_scores(run))
    kept = cap_indices(scores, cap) if scores is not None else list(range(cap))
    left = sorted(set(range(len(panels.keys))) - set(kept))
    capped = Capped(
        name=name,
        noun=panels.noun,
        drawn=tuple(panels.keys[i] for i in kept),
        left_out=tuple(panels.keys[i] for i in left),
        pages=opts.max_pages,
        max_panels=opts.max_panels,
    )
    return panels.subset(kept), capped
