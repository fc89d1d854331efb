"""Draw and save figure pages in worker processes when the machine has CPUs to spare.

Drawing a page is matplotlib's per-axes Python and PNG encoding: one CPU per page, and
the pages are independent. :func:`save_pages` hands them to up to :func:`page_workers`
forked processes (each draws and saves one page at a time, the heaviest first), so the
figures of a run take about the time of their slowest half on two CPUs. The workers are
forked from the caller after every page's panels were built (the run's tables are
shared copy-on-write, nothing is pickled but page numbers and file paths); each page is
drawn by the same code in the same matplotlib state as in the caller, so the files are
byte-identical to drawing them one after the other. One CPU, one page, a platform
without ``fork``, a daemonic process or a thread other than the main one (``coopproc
batch``'s Dask workers): the pages are drawn in the caller.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from coopproc.memory import gives_back

__all__ = ["MAX_WORKERS", "page_workers", "save_pages"]

#: Most worker processes (each holds one page's figure while drawing it).
MAX_WORKERS = 4

#: The pages and saver of the current :func:`save_pages` call, inherited by the forked
#: workers (closures over the run's tables cannot be pickled and need not be).
_JOB: tuple[Sequence[Any], Callable[[Any], list[Path]]] | None = None


def page_workers() -> int:
    """Worker processes for drawing pages: the CPUs this process may use, at most
    :data:`MAX_WORKERS`; 1 (draw in the caller) without ``fork``, with one CPU, in a
    daemonic process (e.g. a Dask worker of ``coopproc batch``, which may not have
    children and shares the CPUs with the other sessions) or off the main thread."""
    if "fork" not in multiprocessing.get_all_start_methods():
        return 1
    if multiprocessing.current_process().daemon:
        return 1
    if threading.current_thread() is not threading.main_thread():
        return 1
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_WORKERS))


# the page's figure and its drawn pixels are freed, but glibc would keep their pages in
# this worker beside the tables it shares with the caller: a day's workers held ~0.5 GB
# each between pages otherwise (issue 11)
@gives_back
def _save_one(index: int) -> list[Path]:
    assert _JOB is not None, "a page worker runs only inside save_pages"
    pages, save = _JOB
    return save(pages[index])


def save_pages(
    pages: Sequence[Any],
    save: Callable[[Any], list[Path]],
    *,
    workers: int | None = None,
    cost: Callable[[Any], float] | None = None,
) -> list[Path]:
    """``save(page)`` for every page (it draws the page and returns the files written),
    in ``workers`` processes (None: :func:`page_workers`); the files in page order.
    ``cost``: a page's relative drawing cost (e.g. its panels), the dearest started first."""
    global _JOB
    n = min(page_workers() if workers is None else workers, len(pages))
    if n <= 1:
        return [path for page in pages for path in save(page)]
    order = sorted(range(len(pages)), key=lambda i: -(cost(pages[i]) if cost else 0.0))
    sys.stdout.flush()  # nothing buffered is written twice by a child
    sys.stderr.flush()
    _JOB = (pages, save)
    try:
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(max_workers=n, mp_context=context) as pool:
            futures = {i: pool.submit(_save_one, i) for i in order}
            return [path for i in range(len(pages)) for path in futures[i].result()]
    finally:
        _JOB = None
