"""The memory a run holds, in one place (issues 11 and 34).

A long run frees most of what it allocates as it goes, but glibc's allocator keeps most
freed C-heap blocks for reuse (it raises its mmap threshold to the largest block freed,
up to 32 MiB, so a pair's arrays or a navigation column come from the heap, and stay
there once freed): without giving them back a day's run held several GB it had freed.
Three things decide what a run holds, and all three are here:

- **Scopes.** A pass's working arrays are the locals of a function and go when it
  returns; :func:`gives_back` marks the passes after which the freed pages go back to the
  system (``malloc_trim``, about a millisecond): the fusion's forward pass and its
  passes before the trajectories are built, the ranging stage's DI passes and each
  pair's rows, each platform's release in positions.csv's table, each figure page in its
  worker. The readers and the checks need none: a phase boundary follows each. No stage
  calls the allocator itself.
- **Phase boundaries.** The runner gives the free pages back as each phase starts
  (:class:`~coopproc.run.progress.PhaseProgress` is built with
  ``on_phase=release_freed_memory``) and once before the figures' workers are forked
  (they would inherit them).
- **Who holds the session's samples** (:class:`Held`): the caller hands the session to
  :func:`~coopproc.run.pipeline.run_pipeline` in a box, so the pipeline can let go of the
  navigation, reference and range rows once the positions table has read them (about
  1.1 GB at a day of 10 platforms) while the caller keeps the rest.

Measured against fixing glibc's thresholds instead (``mallopt``: every block of 128 KiB
or more mapped on its own and unmapped when freed, so no scope need be marked): at 10
platforms x 1 h it cost 15 % of the wall time (32.3 -> 37.0 s, reading and writing the
tables most: each of their buffers is mapped afresh) for the same peak (0.80 -> 0.81 GB),
and at a day 590 -> 640 s for 7.77 -> 7.69 GB; thresholds of 1, 4 and 32 MiB and a
thread trimming every 0.25 s were slower or held more (docs/scale.md).
"""

from __future__ import annotations

import ctypes
import functools
import sys
from collections.abc import Callable
from typing import Generic, ParamSpec, TypeVar

__all__ = ["Held", "gives_back", "release_freed_memory"]

T = TypeVar("T")
P = ParamSpec("P")
R = TypeVar("R")


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None).malloc_trim  # type: ignore[no-any-return]
    except (OSError, AttributeError):  # not glibc (musl has none)
        return None


def release_freed_memory() -> None:
    """Give the C heap's free pages back to the system (glibc ``malloc_trim``); a no-op
    where there is no ``malloc_trim``. Called at the runner's phase boundaries and by the
    scopes :func:`gives_back` marks."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def gives_back(function: Callable[P, R]) -> Callable[P, R]:
    """Mark ``function`` a scope whose working memory goes back to the system when it
    returns: its locals are freed then, and the heap's free pages with them (see the
    module docstring for where it is used and why)."""

    @functools.wraps(function)
    def scoped(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return function(*args, **kwargs)
        finally:
            release_freed_memory()

    return scoped


class Held(Generic[T]):
    """A large input handed over in a box, so the callee may replace it while the caller
    waits (Python keeps an argument alive in the caller's frame; a box it does not).

    The caller builds the box and keeps no other reference to the value; the callee reads
    :attr:`value` and, once it has read what it needed, :meth:`replace` s it with what the
    caller should get back (``run_pipeline``: the session without its samples)."""

    __slots__ = ("_value",)

    def __init__(self, value: T) -> None:
        self._value = value

    @property
    def value(self) -> T:
        return self._value

    def replace(self, value: T) -> None:
        self._value = value

    def __repr__(self) -> str:
        return f"Held({type(self._value).__name__})"
