"""Ctrl-C in ``coopproc batch`` (issue 32): noticed, not raised; the Dask cluster closed
quietly; nothing half-made left (used by :mod:`coopproc.run.batch`).

SIGINT is caught while the cluster runs (:class:`SigintFlag` only notes it; the wait for
the next finished session looks at it every ``POLL_S``), so Dask never sees a
KeyboardInterrupt in its event loop and prints none of its tracebacks. The local
cluster's worker processes are spawned with SIGINT ignored (:meth:`SigintFlag.ignored`:
a caught handler is reset by exec, a blocked mask too, measured) and log nothing below
ERROR (:func:`quiet_workers`); this process's Dask loggers are silenced while the
cluster closes (:func:`dask_silenced`: the nanny's "still alive after 4 s, killing" on a
loaded machine is not the user's concern). After the close, a session a worker finished
meanwhile counts as finished (:func:`written_since`), and :func:`clean_after_interrupt`
removes the unfinished sessions' temporary output directories (each output appears
whole or not at all: :func:`coopproc.io.outdir.atomic_output_dir`) and ROOT when this
call made it and nothing finished.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import logging
import shutil
import signal
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path

from coopproc.run.batch_root import run_json

__all__ = ["SigintFlag", "clean_after_interrupt", "dask_silenced", "quiet_workers", "written_since"]


class SigintFlag:
    """A SIGINT handler that only notes the signal (installed from the main thread)."""

    def __init__(self) -> None:
        self.hit = False
        self._previous: object = None
        self._installed = False

    def __call__(self, signum: int, frame: object) -> None:
        self.hit = True

    def __enter__(self) -> SigintFlag:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self)
            self._installed = True
        return self

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)  # type: ignore[arg-type]

    @contextlib.contextmanager
    def ignored(self) -> Iterator[None]:
        """SIGINT ignored for the block (the local cluster's start).

        Processes spawned meanwhile inherit the ignored disposition (a caught one is
        reset by exec, and a blocked mask too, measured): the cluster's worker processes
        so never see a Ctrl-C, each of which would print a KeyboardInterrupt traceback of
        its own. A Ctrl-C during those few seconds is lost; from the first session on it
        is acted on.
        """
        if not self._installed:
            yield
            return
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, self)


def quiet_workers() -> object:
    """A Dask worker plugin: the local cluster's workers log nothing below CRITICAL.

    A session's failure reaches the user through its task (one line each, batch.py) and a
    worker killed for memory through the scheduler's events (batch_memory.py), not through
    a worker's log; at ERROR, a worker whose heartbeat met the scheduler closing after a
    Ctrl-C printed "Failed to communicate with scheduler" and a 30-line traceback (seen in
    the slow suite's Ctrl-C test)."""
    from distributed import WorkerPlugin

    class QuietWorkers(WorkerPlugin):
        name = "coopproc-quiet-workers"

        def setup(self, worker: object) -> None:
            logging.getLogger("distributed").setLevel(logging.CRITICAL)

    return QuietWorkers()


@contextlib.contextmanager
def dask_silenced(on: bool = True) -> Iterator[None]:
    """This process's Dask loggers at CRITICAL for the block (``on``; else as they are).

    Used for the cluster's close, and for a local cluster's whole run: its nannies and
    scheduler live in this process and log a worker killed for memory at WARNING and
    ERROR, which the session's one line (batch_memory.py) says instead."""
    logger = logging.getLogger("distributed")
    level = logger.level
    if on:
        logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def written_since(out_dir: Path, started: str) -> bool:
    """``out_dir`` holds a run that started at ``started`` or later (one this call's
    worker finished while the cluster closed)."""
    info = run_json(out_dir)
    when = info.get("start_time") if info is not None else None
    try:
        return isinstance(when, str) and dt.datetime.fromisoformat(
            when
        ) >= dt.datetime.fromisoformat(started)
    except ValueError:
        return False


def clean_after_interrupt(out_root: Path, unfinished: Sequence[str], made_root: bool) -> None:
    """Remove what the unfinished sessions' killed workers left (their temporary output
    directories, ``.<name>.*.tmp``) and ROOT when this call made it and it is empty."""
    for name in unfinished:
        for tmp in out_root.glob(f".{name}.*.tmp"):
            shutil.rmtree(tmp, ignore_errors=True)
    if made_root:
        with contextlib.suppress(OSError):  # not empty: something finished, or another's
            out_root.rmdir()
