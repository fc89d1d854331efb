"""Which methods a run has: read from the run, never assumed.

A run's processing chain is configurable: it may drop methods (no ``rn``; fusion only with
``observed``) or add new ones (a range processor ``median``, a position estimator
``lsq``). Every reporter takes its method lists from here:

- ``run.json`` key ``"methods"`` (written by ``coopproc run``), e.g.
  ``{"ranges": ["observed", "rn", "di"], "positions": ["observed", "rn", "di"]}``:
  ``ranges`` are the method columns of ``ranges.csv`` (``observed`` included), in chain
  order; ``positions`` the ``method`` values of ``positions.csv`` other than ``nav`` and
  ``reference``. An optional ``"nlos"`` list names the methods that detect NLOS, an
  optional ``"primary"`` (one name, or none) the processed range method the headline and
  paper 000's figures compare with the observed ranges (the one its range processor
  declares primary, ``di``; else the last processed one).
- Without that key (older run directories, in-memory tables), from the data: range
  methods are the numeric columns of ``ranges`` other than ``time, pair, reference,
  nlos_flag, nlos_estimate``; position methods the distinct ``method`` values other than
  ``nav`` / ``reference``. Known names come first in :data:`coopproc.model.METHODS`
  order (a display order hint only), then the others in column order (ranges) or
  alphabetically (positions).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import pandas as pd

from coopproc.model import METHODS
from coopproc.report.run_tables import RunTables

__all__ = [
    "METHOD_KEYS",
    "NLOS_DETECTORS",
    "NOT_POSITION_METHODS",
    "NOT_RANGE_METHODS",
    "detection_methods_of",
    "listed_methods",
    "method_order",
    "nlos_methods",
    "position_methods",
    "position_methods_of",
    "primary_method",
    "processed_methods",
    "range_methods",
    "range_methods_of",
]

#: Columns of ``ranges`` that are not range methods.
NOT_RANGE_METHODS = frozenset(
    {"time", "pair", "reference", "nlos_flag", "nlos_estimate", "outlier"}
)
#: ``method`` values of ``positions`` that are not position methods.
NOT_POSITION_METHODS = frozenset({"nav", "reference"})
#: Known range methods that detect NLOS (scored even when they found no event); any other
#: method detects NLOS when it has events in ``nlos_events``.
NLOS_DETECTORS: tuple[str, ...] = ("rn", "di")
#: Keys of run.json ``"methods"``; each a list of method names.
METHOD_KEYS: tuple[str, ...] = ("ranges", "positions", "nlos", "primary")
#: The primary processed range method of a run directory that does not list one (written
#: before run.json had ``methods.primary``), when it has it (fig. 9-11 of paper 000).
_PRIMARY = "di"


def _known_first(names: Iterable[str], *, sort_rest: bool) -> tuple[str, ...]:
    names = list(dict.fromkeys(names))
    known = [m for m in METHODS if m in names]
    rest = [m for m in names if m not in METHODS]
    return (*known, *(sorted(rest) if sort_rest else rest))


def range_methods_of(ranges: pd.DataFrame) -> tuple[str, ...]:
    """Range methods derived from a ranges table (see the module doc)."""
    names = [
        str(c)
        for c in ranges.columns
        if c not in NOT_RANGE_METHODS and (c in METHODS or pd.api.types.is_numeric_dtype(ranges[c]))
    ]
    return _known_first(names, sort_rest=False)


def position_methods_of(positions: pd.DataFrame) -> tuple[str, ...]:
    """Position methods derived from a positions table (see the module doc)."""
    if "method" not in positions.columns:
        return ()
    names = [str(m) for m in positions["method"].dropna().unique()]
    return _known_first((m for m in names if m not in NOT_POSITION_METHODS), sort_rest=True)


def detection_methods_of(
    range_methods: Sequence[str], nlos_events: pd.DataFrame | None
) -> tuple[str, ...]:
    """Methods that detect NLOS: the range methods that are known detectors or have events,
    in range-method order, then other methods with events alphabetically."""
    with_events: set[str] = set()
    if nlos_events is not None and "method" in nlos_events.columns:
        with_events = {str(m) for m in nlos_events["method"].dropna().unique()}
    found = [
        m for m in range_methods if m != "observed" and (m in NLOS_DETECTORS or m in with_events)
    ]
    extra = sorted(with_events - set(found) - {"observed"})
    return (*found, *extra)


def listed_methods(info: Mapping[str, Any], key: str) -> tuple[str, ...] | None:
    """``info["methods"][key]`` as a tuple, or None when the run does not list it."""
    methods = info.get("methods")
    if not isinstance(methods, Mapping):
        return None
    listed = methods.get(key)
    if not isinstance(listed, list | tuple) or not all(isinstance(m, str) for m in listed):
        return None
    return tuple(dict.fromkeys(listed))


def range_methods(run: RunTables) -> tuple[str, ...]:
    """The run's range methods (``observed`` included), those that have a ranges column."""
    listed = listed_methods(run.info, "ranges")
    if listed is None:
        return range_methods_of(run.ranges)
    return tuple(m for m in listed if m in run.ranges.columns)


def position_methods(run: RunTables) -> tuple[str, ...]:
    """The run's position methods (without ``nav`` and ``reference``)."""
    listed = listed_methods(run.info, "positions")
    if listed is None:
        return position_methods_of(run.positions)
    return tuple(m for m in listed if m not in NOT_POSITION_METHODS)


def processed_methods(run: RunTables) -> tuple[str, ...]:
    """The range methods other than ``observed``, in run order."""
    return tuple(m for m in range_methods(run) if m != "observed")


def primary_method(run: RunTables) -> str | None:
    """run.json ``methods.primary`` if listed (and the run has it); else ``di`` if the run
    has it, else its last processed range method, else None."""
    processed = processed_methods(run)
    listed = listed_methods(run.info, "primary")
    if listed is not None:
        return next((m for m in listed if m in processed), None)
    if _PRIMARY in processed:
        return _PRIMARY
    return processed[-1] if processed else None


def nlos_methods(run: RunTables) -> tuple[str, ...]:
    """Methods that detect NLOS: run.json ``methods.nlos`` if listed, else derived."""
    listed = listed_methods(run.info, "nlos")
    if listed is not None:
        return listed
    return detection_methods_of(range_methods(run), run.nlos_events)


def method_order(names: Iterable[str], order: Sequence[str]) -> list[str]:
    """``names`` (each once) sorted by their place in ``order``; others keep their order, last."""
    rank = {m: i for i, m in enumerate(order)}
    unique = list(dict.fromkeys(names))
    return sorted(unique, key=lambda m: rank.get(m, len(rank)))
