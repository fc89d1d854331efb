"""Independent position steps of the chain at the same time, one in a forked child (issue 11).

Once the ranging step has run, the fusions of the processed range sets (``fusion (rn)``,
``fusion (di)``) need nothing from each other: each takes about a minute at a day of 10
platforms. :func:`group_steps` puts such steps (position steps whose inputs are all
there before the first of them starts, next to each other in the chain) in one group of
at most :func:`workers` steps; :func:`run_concurrently` runs a group's first step in the
caller and each other one in a child process forked from it (the child sees the session
and the range sets copy-on-write, nothing is pickled on the way in). The child sends its
:class:`~coopproc.stages.base.PositionProduct` back through a pipe, its arrays as
out-of-band pickle buffers received straight into the caller's memory (one copy of the
product in each process, never two). The step runs the same code on the same inputs:
the product is bit for bit the sequential one.

Forking is allowed where :mod:`coopproc.report.page_workers` allows it: ``fork`` exists,
the process is not daemonic (``coopproc batch``'s Dask workers) and this is the main
thread. ``[run] parallel_fusion``: ``"auto"`` (the default) also wants two CPUs, at
least :data:`MIN_ROWS` range rows (below, a fusion takes about a second and forking is
not worth it) and the second fusion's memory (:data:`BYTES_PER_ROW`) at most
:data:`MAX_EXTRA_BYTES` and twice available; ``true`` only the fork rules; ``false``
never forks. Two fusions at once hold two fusions' working arrays: the run's peak
memory grows by about one fusion's (PSS summed over both processes: +0.3 GB at 20
platforms x 1 h, +0.55-0.65 GB at 10 x 4 h, +3 GB at a day of 10 platforms).

An error in the child (e.g. a :class:`~coopproc.errors.StageError`) is raised in the
caller as it would have been raised there; a child that dies (killed, e.g. for memory)
is a :class:`~coopproc.errors.StageError` naming the step, not a hang.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from typing import Any, Literal, TypeVar

from coopproc.errors import CoopprocError, StageError
from coopproc.run.chain import Step

__all__ = [
    "BYTES_PER_ROW",
    "MIN_ROWS",
    "can_fork",
    "group_label",
    "group_steps",
    "run_concurrently",
    "workers",
]

T = TypeVar("T")

#: Range rows from which ``parallel_fusion = "auto"`` runs independent steps at once
#: (about 10 platforms x 10 minutes; below, a fusion takes about a second).
MIN_ROWS = 200_000

#: Memory a second fusion at the same time holds, per range row (its working arrays and
#: product; measured 0.5-0.9 kB at 20 x 1 h and 10 x 4 h, 0.8 kB at a day of 10
#: platforms): ``"auto"`` forks only when that is at most :data:`MAX_EXTRA_BYTES` and
#: twice it fits in the memory available.
BYTES_PER_ROW = 1_000

#: The most memory ``"auto"`` lets a second fusion add to the run's peak (1 M range rows,
#: e.g. 10 platforms x 6 h or 20 x 1.5 h; beyond, the fusions run one after the other
#: unless ``parallel_fusion = true``).
MAX_EXTRA_BYTES = 1_000_000_000

#: Most steps of one group (the caller's and one child's: two fusions at once already
#: hold two fusions' working memory).
MAX_GROUP = 2


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """``fork`` exists, this process may have children (not daemonic) and this is the
    main thread (the rules of :func:`coopproc.report.page_workers.page_workers`)."""
    return (
        "fork" in multiprocessing.get_all_start_methods()
        and not multiprocessing.current_process().daemon
        and threading.current_thread() is threading.main_thread()
    )


def _available_bytes() -> int | None:
    """The memory available to new allocations (Linux MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None  # no /proc/meminfo (not Linux) or unreadable: unknown
    return None  # a kernel without MemAvailable: unknown


def workers(setting: bool | Literal["auto"], rows: int) -> int:
    """Steps run at once for ``[run] parallel_fusion = setting`` on ``rows`` range rows:
    :data:`MAX_GROUP`, or 1 (one after the other, as without this module)."""
    if setting is False or not can_fork():
        return 1
    if setting == "auto":
        if _cpus() < 2 or rows < MIN_ROWS:
            return 1
        extra = BYTES_PER_ROW * rows
        available = _available_bytes()
        if extra > MAX_EXTRA_BYTES or (available is not None and 2 * extra > available):
            return 1
    return MAX_GROUP


def group_steps(steps: Sequence[Step], size: int) -> list[tuple[Step, ...]]:
    """``steps`` (in run order) cut into groups run at once: consecutive position steps
    whose inputs all exist before the group's first step, at most ``size`` a group; every
    other step alone. Concatenated, the groups are ``steps`` in the same order."""
    available = {"ranges:observed"}
    groups: list[tuple[Step, ...]] = []
    current: list[Step] = []
    for step in steps:
        joins = (
            bool(current)
            and len(current) < size
            and step.kind == "positions"
            and current[0].kind == "positions"
            and set(step.inputs) <= available
        )
        if not joins and current:
            groups.append(tuple(current))
            available.update(o for s in current for o in s.outputs)
            current = []
        current.append(step)
    if current:
        groups.append(tuple(current))
    return groups


def group_label(group: Sequence[Step]) -> str:
    """How progress and run.json ``timings_s`` name a group: the step's own label alone,
    ``fusion (rn, di)`` for one stage on several range sets, else the labels joined."""
    if len(group) == 1:
        return group[0].label
    if all(s.kind == "positions" and s.stage == group[0].stage for s in group):
        return f"{group[0].stage} ({', '.join(str(s.range_set) for s in group)})"
    return ", ".join(s.label for s in group)


def run_concurrently(jobs: Sequence[Callable[[], T]], labels: Sequence[str]) -> list[T]:
    """Every job's return value, in order: ``jobs[0]`` here, each other one in a forked
    child (module docstring). ``labels`` name the jobs in errors."""
    if len(jobs) <= 1:
        return [job() for job in jobs]
    sys.stdout.flush()  # nothing buffered is written twice by a child
    sys.stderr.flush()
    children: list[_Child] = []
    try:
        for job, label in zip(jobs[1:], labels[1:], strict=True):
            children.append(_Child(job, label))
        results = [jobs[0]()]
        results += [child.result() for child in children]
        return results
    finally:
        for child in children:
            child.stop()


class _Child:
    """``job()`` in a forked child; :meth:`result` receives its return value."""

    def __init__(self, job: Callable[[], Any], label: str) -> None:
        self._label = label
        context = multiprocessing.get_context("fork")
        self._recv, send = context.Pipe(duplex=False)
        self._process = context.Process(target=_child_main, args=(send, job), daemon=True)
        self._process.start()
        send.close()  # the child's end only: its death is EOF here, not a hang

    def result(self) -> Any:
        """The child's return value; its exception raised here; StageError if it died."""
        try:
            status, value = _receive(self._recv)
        except (EOFError, OSError):
            self._process.join()
            raise StageError(
                f"{self._label}: the worker process running it ended without a result "
                f"({_how(self._process.exitcode)}); [run] parallel_fusion = false runs "
                "the steps one after the other"
            ) from None
        finally:
            self._recv.close()
        self._process.join()
        if status == "error":
            raise value
        return value

    def stop(self) -> None:
        """End the child if it still runs (the caller failed first) and reap it."""
        if self._process.is_alive():
            self._process.kill()
        self._process.join()
        self._recv.close()


def _how(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"killed by {name}" + (", e.g. for memory" if name == "SIGKILL" else "")
    return f"exit code {exitcode}"


def _child_main(conn: Connection, job: Callable[[], Any]) -> None:
    try:
        payload: tuple[str, Any] = ("ok", job())
    except BaseException as err:  # every failure goes back to the caller
        payload = ("error", _portable(err))
    try:
        _send(conn, payload)
    finally:
        conn.close()


def _portable(err: BaseException) -> BaseException:
    """``err`` if it survives pickling, else the same message as the nearest error the
    caller can rebuild (a StageError for coopproc's own errors)."""
    err.add_note(f"(raised in a worker process)\n{''.join(traceback.format_exception(err))}")
    try:
        pickle.loads(pickle.dumps(err))
    except Exception:  # e.g. an exception class with required kwargs
        kind = StageError if isinstance(err, CoopprocError) else RuntimeError
        rebuilt = kind(str(err))
        for note in getattr(err, "__notes__", ()):
            rebuilt.add_note(note)
        return rebuilt
    return err


def _send(conn: Connection, payload: Any) -> None:
    """The payload pickled with its large buffers (numpy arrays) out of band: their sizes,
    the pickle, then each buffer as it is in memory (no copy)."""
    buffers: list[pickle.PickleBuffer] = []
    head = pickle.dumps(payload, protocol=5, buffer_callback=buffers.append)
    views = [b.raw() for b in buffers]
    conn.send([v.nbytes for v in views])
    conn.send_bytes(head)
    for view in views:
        conn.send_bytes(view)


def _receive(conn: Connection) -> Any:
    sizes: list[int] = conn.recv()
    head = conn.recv_bytes()
    buffers = []
    for size in sizes:
        buffer = bytearray(size)
        if size:
            conn.recv_bytes_into(buffer)
        else:
            conn.recv_bytes()
        buffers.append(buffer)
    return pickle.loads(head, buffers=buffers)
