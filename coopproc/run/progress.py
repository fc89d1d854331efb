"""Progress of a long command, phase by phase: a bar on a terminal, else one line per phase.

A run is a sequence of phases (reading, each stage of the chain, writing the tables, the
figures, the HTML report). :class:`PhaseProgress` is told when each phase starts; on a
terminal it advances a tqdm bar named after the running phase, otherwise (a log file, a
batch job) it writes one line per finished phase with its duration and the elapsed time,
so that a user watching a 10-minute run, or reading its log later, sees where the time
went. It also keeps each phase's duration (:attr:`timings_s`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from types import TracebackType
from typing import Any

__all__ = ["PhaseProgress"]


class PhaseProgress:
    """Phases of one command (see the module docstring).

    ``total``: the number of phases expected (for the bar); ``bar``: show a tqdm bar
    (a terminal); ``log``: where the per-phase lines go when there is no bar (None: nowhere);
    ``prefix``: the start of each line (e.g. "run"); ``on_phase``: called as each phase
    starts, inside its time (the runner gives back the freed memory there, memory.py).
    """

    def __init__(
        self,
        total: int,
        *,
        bar: bool,
        log: Callable[[str], None] | None,
        prefix: str = "",
        clock: Callable[[], float] = time.perf_counter,
        on_phase: Callable[[], None] | None = None,
    ) -> None:
        self._clock = clock
        self._on_phase = on_phase
        self._started = clock()
        self._current: str | None = None
        self._since = self._started
        self._log = None if bar else log
        self._prefix = f"{prefix}: " if prefix else ""
        self.timings_s: dict[str, float] = {}
        self._bar: Any = None
        if bar:
            from tqdm import tqdm

            self._bar = tqdm(total=total, unit="phase", leave=False)

    def set_total(self, total: int) -> None:
        """The number of phases expected, once it is known better (e.g. after reading)."""
        if self._bar is not None:
            self._bar.total = total
            self._bar.refresh()

    def start(self, label: str) -> None:
        """Phase ``label`` starts now (the running one, if any, has ended)."""
        self.end()
        self._current = label
        self._since = self._clock()
        if self._on_phase is not None:  # e.g. the runner's memory (memory.py), timed here
            self._on_phase()
        if self._bar is not None:
            self._bar.set_description(label)

    def end(self) -> None:
        """The running phase, if any, has ended: record it (and log or tick it)."""
        if self._current is None:
            return
        now = self._clock()
        took = now - self._since
        label = self._current
        self.timings_s[label] = self.timings_s.get(label, 0.0) + took
        self._current = None
        if self._bar is not None:
            self._bar.update(1)
        elif self._log is not None:
            self._log(
                f"{self._prefix}{label} done in {took:.1f} s (elapsed {now - self._started:.1f} s)"
            )

    def close(self) -> None:
        """End the running phase and remove the bar."""
        self.end()
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> PhaseProgress:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if kind is None:
            self.close()
        elif self._bar is not None:  # an error: no line for a phase that did not finish
            self._bar.close()
            self._bar = None
