"""Each local worker's memory bound (``coopproc batch --worker-memory``, issue 35 part 3),
and a worker that died, for memory or otherwise, as its session's one-line failure.

The local cluster's nannies terminate a worker whose resident memory passes
``TERMINATE_FRACTION`` of its limit (Dask's memory monitor, every 100 ms) and log a
``worker-restart-memory`` event on the scheduler; the session it ran then fails with
Dask's KilledWorker, at once (no retry: the same session needs the same memory again),
and the others go on on the restarted worker. Dask's spilling and pausing are off: the
workers hold no Dask data to spill (one session's outcome each), and a worker paused at
80 % would take no further session while its process keeps the memory of the last one.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any

from coopproc.errors import CoopprocError

__all__ = [
    "TERMINATE_FRACTION",
    "died_message",
    "failure_line",
    "format_size",
    "local_cluster_config",
    "machine_memory",
    "worker_memory_limit",
]

#: A worker is terminated above this fraction of its limit (Dask's default, 0.95).
TERMINATE_FRACTION = 0.95


def machine_memory() -> int:
    """This machine's memory in bytes, as Dask sees it (cgroup and RLIMIT_RSS honoured)."""
    from distributed.system import MEMORY_LIMIT

    return int(MEMORY_LIMIT)


def format_size(n_bytes: float) -> str:
    """``3.00 GB`` (decimal units, like ``--worker-memory 3GB``)."""
    return f"{n_bytes / 1e9:.2f} GB"


def worker_memory_limit(size: str | None, workers: int) -> tuple[int, str | None]:
    """Bytes per local worker for ``--worker-memory SIZE`` (None: the default), and the
    note to print when SIZE was capped.

    The default is this machine's memory divided by the workers, so that together they
    never ask for more than there is; a SIZE above the machine's memory is capped at it
    (Dask would do so with a log line). A SIZE that is no size, or not above 0, is
    refused with one line.
    """
    total = machine_memory()
    if size is None:
        return total // workers, None
    from dask.utils import parse_bytes

    try:
        n_bytes = int(parse_bytes(size.strip()))
    except (ValueError, TypeError, KeyError) as err:
        raise CoopprocError(
            f"--worker-memory {size!r}: not a size; expected e.g. 3GB, 1.5GiB or 800MB"
        ) from err
    if n_bytes <= 0:
        raise CoopprocError(f"--worker-memory {size!r}: must be above 0 (e.g. 3GB)")
    if n_bytes > total:
        return total, (
            f"batch: --worker-memory {size} is more than this machine's "
            f"{format_size(total)}; each worker is limited to that"
        )
    return n_bytes, None


def local_cluster_config() -> dict[str, Any]:
    """Dask settings for the local cluster's scheduler and nannies (module docstring)."""
    return {
        "distributed.scheduler.allowed-failures": 0,
        # one session per worker: none waits on a worker that a kill would fail with it
        "distributed.scheduler.worker-saturation": 1.0,
        "distributed.worker.memory.target": False,
        "distributed.worker.memory.spill": False,
        "distributed.worker.memory.pause": False,
        "distributed.worker.memory.terminate": TERMINATE_FRACTION,
    }


def died_message(
    session: str, worker: str, memory_events: Iterable[tuple[float, Any]], limit: int | None
) -> str:
    """The one line of a session whose worker died (Dask's KilledWorker).

    ``memory_events`` are the scheduler's ``worker-restart-memory`` events
    (``(time, {"worker": address, "rss": bytes, ...})``); ``limit`` the local cluster's
    per-worker limit (None: a cluster given by ``--scheduler``, whose limits are its own).
    """
    rss = [
        e.get("rss") for _, e in memory_events if isinstance(e, dict) and e.get("worker") == worker
    ]
    if rss:
        used = f" ({format_size(rss[-1])})" if isinstance(rss[-1], int | float) else ""
        if limit is None:
            return (
                f"{session}: its Dask worker was terminated for using more memory than its "
                f"limit{used}; give the cluster's workers more memory"
            )
        return (
            f"{session}: its Dask worker was terminated for using more than "
            f"{TERMINATE_FRACTION:.0%} of its memory limit of {format_size(limit)}{used}; "
            "the session needs more: raise --worker-memory or use fewer --workers"
        )
    return (
        f"{session}: its Dask worker died while running it (killed by the system, out of "
        "memory, or lost); the other sessions went on"
    )


def failure_line(client: Any, err: Exception, session: str, limit: int | None) -> str:
    """The one line of a task that raised: a dead worker's cause, else the exception."""
    from distributed.scheduler import KilledWorker

    if not isinstance(err, KilledWorker):
        return f"{type(err).__name__}: {err}"
    last = err.last_worker
    worker = str(getattr(last, "address", last))
    events: tuple[tuple[float, Any], ...] = ()
    for _ in range(10):  # the nanny's event may reach the scheduler after the death
        events = tuple(client.get_events("worker-restart-memory"))
        if any(isinstance(e, dict) and e.get("worker") == worker for _, e in events):
            break
        time.sleep(0.1)
    return died_message(session, worker, events, limit)
