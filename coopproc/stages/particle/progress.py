"""Progress of ``coopproc locate``: each method's epochs (issue 17, item 5).

The filters call a :data:`ProgressFn` ``(method, done, total)`` after each epoch.
:class:`EpochProgress` turns those calls into a tqdm bar per method on a terminal, or,
in a log (no terminal), one line per tenth of a method's epochs and one when it ends:

    locate: aacopf 30% (90/300 epochs, 4.1 s)
    locate: aacopf done in 13.6 s (300 epochs, 22.1 epochs/s)
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

__all__ = ["EpochProgress", "ProgressFn"]

#: (method, epochs done, epochs in all), called after every epoch.
ProgressFn = Callable[[str, int, int], None]


class EpochProgress:
    """A :data:`ProgressFn` that shows a bar (``bar``) or writes lines to ``log``."""

    def __init__(
        self,
        *,
        bar: bool,
        log: Callable[[str], None] | None,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self._bar_wanted = bar
        self._log = None if bar else log
        self._clock = clock
        self._method: str | None = None
        self._start = 0.0
        self._next_tenth = 1
        self._bar: Any = None

    def __call__(self, method: str, done: int, total: int) -> None:
        if method != self._method:
            self._begin(method, total)
        if self._bar is not None:
            self._bar.update(done - self._bar.n)
        elif self._log is not None and total > 0 and done < total:
            while done * 10 >= self._next_tenth * total:
                self._log(
                    f"locate: {method} {10 * self._next_tenth}% ({done}/{total} epochs, "
                    f"{self._clock() - self._start:.1f} s)"
                )
                self._next_tenth += 1
        if done >= total:
            self._finish(total)

    def _begin(self, method: str, total: int) -> None:
        self.close()
        self._method = method
        self._start = self._clock()
        self._next_tenth = 1
        if self._bar_wanted:
            from tqdm import tqdm

            self._bar = tqdm(total=total, unit="epoch", desc=f"locate {method}", leave=False)

    def _finish(self, total: int) -> None:
        took = self._clock() - self._start
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        if self._log is not None:
            rate = f", {total / took:.1f} epochs/s" if took > 0 else ""
            self._log(f"locate: {self._method} done in {took:.1f} s ({total} epochs{rate})")
        self._method = None

    def close(self) -> None:
        """Remove a bar left open (a method that stopped early)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        self._method = None
