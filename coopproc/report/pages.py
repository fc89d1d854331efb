"""Which panels a figure shows and how they are split into pages.

A run of 20 platforms has 190 pairs: one panel per pair in one PNG is 28,000 pixels high
and unreadable. :class:`FigureOptions` chooses the pairs and platforms to draw
(``--pairs``, ``--platforms``) and the most panels per page (``--max-panels``, default
:data:`~coopproc.report.style.MAX_PANELS`); a figure of more panels is saved as
``name.png``, ``name_2.png``, ``name_3.png``... (the first page keeps the figure's name).
Panel labels run on across pages: (a)...(z), (aa), (ab)... (:func:`panel_letter`).

Selection: ``pairs`` restricts the per-pair figures (distance and DI errors, NLOS
convergence) to those pairs; ``platforms`` restricts the per-platform figures (position
errors, trajectories, CDFs, error tracks) to those platforms. Given alone, ``platforms``
also keeps the pairs whose two platforms are both chosen, and ``pairs`` alone keeps the
platforms of the chosen pairs, so either option draws one sub-network.

Cap: unless pairs or platforms were chosen, a figure draws at most ``max_pages`` pages
(``--max-pages``, default :data:`~coopproc.report.style.MAX_PAGES`; 0: all), the panels
most worth looking at (:mod:`coopproc.report.panel_cap`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import pandas as pd

from coopproc.errors import ConfigError
from coopproc.model import pair_members, pair_name
from coopproc.report.run_tables import RunTables
from coopproc.report.style import DEFAULT_STYLE, MAX_PAGES, MAX_PANELS, FigureStyle

__all__ = [
    "FigureOptions",
    "check_names",
    "check_selection",
    "page_ranges",
    "page_stem",
    "panel_label",
    "panel_letter",
    "run_pairs",
    "run_platforms",
    "selection_note",
]


@dataclass(frozen=True)
class FigureOptions:
    """The pairs and platforms to draw (None: all), the most panels per page, the figure
    style (sizes and fonts, ``--style``) and the most pages of a figure whose panels were
    not chosen (``max_pages``; 0: no cap)."""

    pairs: tuple[str, ...] | None = None
    platforms: tuple[str, ...] | None = None
    max_panels: int = MAX_PANELS
    style: FigureStyle = DEFAULT_STYLE
    max_pages: int = MAX_PAGES

    def __post_init__(self) -> None:
        if self.max_panels < 1:
            raise ConfigError(f"max panels must be at least 1, not {self.max_panels}")
        if self.max_pages < 0:
            raise ConfigError(f"max pages must be at least 0 (0: all), not {self.max_pages}")

    @property
    def panel_cap(self) -> int | None:
        """Most panels a figure draws, None for all: the cap applies only when neither
        pairs nor platforms were chosen (what the user chose is drawn whole)."""
        if self.selects or self.max_pages == 0:
            return None
        return self.max_pages * self.max_panels

    def keep_pair(self, pair: str) -> bool:
        """Whether the per-pair figures draw ``pair`` (see the module docstring)."""
        if self.pairs is not None:
            return pair in self.pairs
        if self.platforms is not None:
            return all(p in self.platforms for p in _members(pair))
        return True

    def keep_platform(self, platform: str) -> bool:
        """Whether the per-platform figures draw ``platform``."""
        if self.platforms is not None:
            return platform in self.platforms
        if self.pairs is not None:
            return any(platform in _members(pair) for pair in self.pairs)
        return True

    @property
    def selects(self) -> bool:
        """True when pairs or platforms were chosen."""
        return self.pairs is not None or self.platforms is not None


def _members(pair: str) -> tuple[str, ...]:
    try:
        return pair_members(pair)
    except ValueError:
        return (pair,)


def panel_letter(i: int) -> str:
    """The label of the ``i``-th panel (from 0): a...z, aa...az, ba... (as spreadsheet
    columns), so labels continue across pages."""
    if i < 0:
        raise ValueError("panel index must be >= 0")
    out = ""
    i += 1
    while i:
        i, rest = divmod(i - 1, 26)
        out = chr(ord("a") + rest) + out
    return out


def panel_label(i: int, text: str) -> str:
    """``(a) text`` for panel ``i`` (from 0)."""
    return f"({panel_letter(i)}) {text}"


def page_stem(name: str, page: int) -> str:
    """File stem of page ``page`` (from 0) of figure ``name``: ``name``, ``name_2``..."""
    return name if page == 0 else f"{name}_{page + 1}"


def page_ranges(n: int, max_panels: int) -> list[range]:
    """The panel indices of each page of a figure of ``n`` panels."""
    return [range(lo, min(lo + max_panels, n)) for lo in range(0, n, max_panels)]


def _unique(frame: pd.DataFrame | None, column: str) -> set[str]:
    if frame is None or column not in frame.columns or not len(frame):
        return set()
    return {str(v) for v in frame[column].dropna().unique()}


def run_pairs(run: RunTables) -> list[str]:
    """Every pair of the run (ranges, DI, metrics, NLOS events), sorted."""
    found = _unique(run.ranges, "pair") | _unique(run.di, "pair") | _unique(run.metrics, "pair")
    return sorted(found | _unique(run.nlos_events, "pair"))


def run_platforms(run: RunTables) -> list[str]:
    """Every platform of the run (positions and the pairs' platforms), sorted."""
    found = _unique(run.positions, "platform") | _unique(run.position_metrics, "platform")
    for pair in run_pairs(run):
        found.update(_members(pair))
    return sorted(found)


def check_names(names: Iterable[str], known: Sequence[str], what: str) -> tuple[str, ...]:
    """``names`` in order without repeats; one not in ``known`` raises ConfigError listing
    ``known``. For ``what == "pair"``, ``B-A`` is taken as the pair ``A-B``."""
    out: list[str] = []
    for name in names:
        if name not in known and what == "pair" and "-" in name:
            a, _, b = name.partition("-")
            swapped = pair_name(a, b)  # B-A is the pair A-B
            name = swapped if swapped in known else name
        if name not in known:
            raise ConfigError(f"unknown {what} {name!r}; the run has {', '.join(known) or 'none'}")
        if name not in out:
            out.append(name)
    return tuple(out)


def check_selection(
    run: RunTables,
    pairs: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    max_panels: int = MAX_PANELS,
    style: FigureStyle = DEFAULT_STYLE,
    max_pages: int = MAX_PAGES,
) -> FigureOptions:
    """:class:`FigureOptions` for ``run``; an unknown pair or platform raises ConfigError
    listing the run's. ``B-A`` is taken as the pair ``A-B``."""
    return FigureOptions(
        pairs=None if pairs is None else check_names(pairs, run_pairs(run), "pair"),
        platforms=None
        if platforms is None
        else check_names(platforms, run_platforms(run), "platform"),
        max_panels=max_panels,
        style=style,
        max_pages=max_pages,
    )


def selection_note(run: RunTables, options: FigureOptions) -> str | None:
    """One sentence saying what the figures leave out by the selection, None if nothing."""
    if not options.selects:
        return None
    pairs = run_pairs(run)
    platforms = run_platforms(run)
    kept_pairs = [p for p in pairs if options.keep_pair(p)]
    kept_platforms = [p for p in platforms if options.keep_platform(p)]
    return (
        f"The figures show {len(kept_pairs)} of the run's {len(pairs)} pairs "
        f"({', '.join(kept_pairs) or 'none'}) and {len(kept_platforms)} of its "
        f"{len(platforms)} platforms ({', '.join(kept_platforms) or 'none'}), as chosen "
        "with --pairs / --platforms; the tables cover them all."
    )
