"""Many sessions at once on Dask: ``coopproc batch SESSION... -o ROOT``.

Each session is one task (read -> pipeline -> write ``ROOT/<name>/``, exactly what
``coopproc run`` writes), run on a Dask cluster: a local one by default, or the scheduler
at ``scheduler`` for a real cluster. ``<name>`` is the session directory's name (an
``.mcap`` file's name without the suffix); two sessions of one name are refused.

Checked before any work: the names, the scheduler (something answers at its address
within a few seconds, :func:`check_scheduler`), ROOT and each ``ROOT/<name>/``
(coopproc.run.batch_plan: replaced only with ``force``, kept by ``resume`` when complete
and current). A session that fails, a missing path included, is reported with its
one-line error and does not stop the others.

``ROOT/batch.json`` and the stacked tables always describe every session under ROOT, not
just this call's (coopproc.run.batch_root.merge_listing).

Ctrl-C (issue 32, :mod:`coopproc.run.batch_interrupt`): one line; the sessions finished
so far are listed in batch.json as usual, nothing half-made is left, and
:class:`BatchInterrupted` is raised with the outcomes so far (the CLI prints the line).
"""

from __future__ import annotations

import asyncio
import datetime as dt
import socket
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from coopproc.errors import CoopprocError
from coopproc.run.batch_interrupt import (
    SigintFlag,
    clean_after_interrupt,
    dask_silenced,
    quiet_workers,
    written_since,
)
from coopproc.run.batch_memory import failure_line, local_cluster_config, machine_memory
from coopproc.run.batch_plan import (
    SessionOutcome,
    failed_outcome,
    make_root,
    os_cause,
    out_names,
    plan_sessions,
)
from coopproc.run.batch_root import BatchEntry, merge_listing, read_listing, run_json, write_listing
from coopproc.run.config import RunConfig

__all__ = [
    "BatchEntry",
    "BatchInterrupted",
    "BatchResult",
    "SessionOutcome",
    "check_scheduler",
    "run_batch",
    "run_one",
]

#: Seconds to wait for the scheduler's port (connect), then for its handshake.
CONNECT_TIMEOUT_S = 5.0
HANDSHAKE_TIMEOUT_S = 10.0

#: Seconds between two looks for finished sessions or a Ctrl-C (a Ctrl-C is acted on
#: within this; the wait costs nothing measurable).
POLL_S = 0.2


class BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C during a batch, after the cleanup: this call's outcomes so far."""

    def __init__(self, outcomes: Sequence[SessionOutcome], out_root: Path) -> None:
        super().__init__("interrupted")
        self.outcomes = tuple(outcomes)
        self.out_root = out_root


@dataclass(frozen=True)
class BatchResult:
    """This call's outcomes (input order), batch.json's entries and the stacked tables."""

    outcomes: tuple[SessionOutcome, ...]
    entries: tuple[BatchEntry, ...]
    metrics_csv: Path | None
    position_metrics_csv: Path | None

    @property
    def failed(self) -> tuple[SessionOutcome, ...]:
        return tuple(o for o in self.outcomes if not o.ok)

    @property
    def skipped(self) -> tuple[SessionOutcome, ...]:
        return tuple(o for o in self.outcomes if o.skipped)


def run_one(
    session_path: str, out_dir: str, config: RunConfig, force: bool, formats: tuple[str, ...]
) -> SessionOutcome:
    """Process one session into ``out_dir`` (the task each Dask worker runs)."""
    import matplotlib

    matplotlib.use("Agg")
    from coopproc.checks.coverage import nav_gap_spans, prepare_run
    from coopproc.io import read_session
    from coopproc.memory import Held, release_freed_memory
    from coopproc.run.output import write_run
    from coopproc.run.pipeline import run_pipeline
    from coopproc.run.progress import PhaseProgress
    from coopproc.run.summary import summarize

    started = dt.datetime.now(dt.UTC)
    started_clock = time.perf_counter()
    # timings only: a worker shows nothing; the runner's memory at each boundary
    phases = PhaseProgress(0, bar=False, log=None, on_phase=release_freed_memory)
    try:
        phases.start("read")
        session = read_session(session_path)
        phases.start("prepare")
        session, _ = prepare_run(session)
        nav_gaps = nav_gap_spans(session)  # run.json's, before the samples are let go of

        # handed over: the pipeline lets go of the samples once its metrics have read them
        held = Held(session)
        del session
        output = run_pipeline(held, config, progress=phases.start)
        session = held.value
        del held
        phases.start("summary")
        facts = summarize(output).facts
        phases.end()
        session = session.without_samples()  # the samples are spent: writing holds none
        write_run(
            output,
            session,
            config,
            out_dir,
            force=force,
            figure_formats=formats,
            started=started,
            started_clock=started_clock,
            summary=facts,
            timings_before={k: phases.timings_s[k] for k in ("read", "prepare")},
            timings_after={"summary": phases.timings_s["summary"]},
            nav_gaps=nav_gaps,
        )
    except CoopprocError as err:
        return failed_outcome(session_path, out_dir, str(err))
    except OSError as err:  # a disk that fills, a file that vanishes under the run
        return failed_outcome(session_path, out_dir, f"{err.filename or out_dir}: {os_cause(err)}")
    return SessionOutcome(session_path, out_dir, ok=True)


def run_batch(
    sessions: Sequence[Path],
    out_root: Path,
    config: RunConfig,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    worker_memory: int | None = None,
    force: bool = False,
    resume: bool = False,
    formats: tuple[str, ...] = ("png",),
    on_done: Callable[[SessionOutcome], None] | None = None,
) -> BatchResult:
    """Run every session on Dask; see the module docstring.

    ``on_done`` is called once per session of this call, as soon as its outcome is known
    (a missing path or a skipped one first). A path given twice is processed once.
    ``worker_memory``: bytes per local worker (None: this machine's memory / ``workers``;
    :mod:`coopproc.run.batch_memory`); a ``scheduler``'s cluster has its own limits.
    """
    started = _now()
    if not sessions:
        raise CoopprocError("batch: no sessions given")
    out_root = Path(out_root)
    unique: dict[Path, Path] = {}
    for s in sessions:
        unique.setdefault(Path(s).resolve(), Path(s))
    paths = list(unique.values())
    names = out_names(paths, out_root)
    if scheduler is not None:
        check_scheduler(scheduler)
    made_root = not out_root.exists()
    make_root(out_root)
    earlier = read_listing(out_root / "batch.json")
    plans = plan_sessions(paths, names, out_root, config, earlier, force=force, resume=resume)
    outcomes = {n: o for n, (o, _) in plans.items() if o is not None}
    for outcome in outcomes.values():
        if on_done is not None:
            on_done(outcome)
    todo = [
        (str(s), str(out_root / n), plans[n][1])
        for s, n in zip(paths, names, strict=True)
        if n not in outcomes
    ]
    interrupted = False
    try:
        limit = None
        if scheduler is None:
            limit = worker_memory if worker_memory is not None else machine_memory() // workers
        local = (workers, processes, limit)
        computed = _compute(todo, config, formats, scheduler, local, on_done)
    except _Interrupted as stop:
        computed, interrupted = stop.outcomes, True
    for outcome in computed:
        outcomes[Path(outcome.out_dir).name] = outcome
    if interrupted:
        for session, name in zip(paths, names, strict=True):
            if name not in outcomes and written_since(out_root / name, started):
                outcomes[name] = SessionOutcome(str(session), str(out_root / name), ok=True)
        clean_after_interrupt(out_root, [n for n in names if n not in outcomes], made_root)
        finished = [outcomes[n] for n in names if n in outcomes]
        if any(not o.skipped for o in finished):  # listed as usual: --resume keeps them
            done = {
                n: _entry(s, n, outcomes[n], out_root, started)
                for s, n in zip(paths, names, strict=True)
                if n in outcomes
            }
            write_listing(out_root, merge_listing(out_root, done, earlier))
        raise BatchInterrupted(finished, out_root)
    this_call = {
        n: _entry(s, n, outcomes[n], out_root, started) for s, n in zip(paths, names, strict=True)
    }
    entries = merge_listing(out_root, this_call, earlier)
    metrics_csv, positions_csv = write_listing(out_root, entries)
    return BatchResult(
        tuple(outcomes[n] for n in names), tuple(entries), metrics_csv, positions_csv
    )


class _Interrupted(Exception):
    """Ctrl-C seen by :func:`_compute` (the cluster closed): the outcomes before it."""

    def __init__(self, outcomes: list[SessionOutcome]) -> None:
        super().__init__("interrupted")
        self.outcomes = outcomes


def _compute(
    todo: Sequence[tuple[str, str, bool]],
    config: RunConfig,
    formats: tuple[str, ...],
    scheduler: str | None,
    local: tuple[int, bool, int | None],
    on_done: Callable[[SessionOutcome], None] | None,
) -> list[SessionOutcome]:
    """Run ``(session, out_dir, force)`` tasks on Dask; their outcomes as they complete.

    ``local``: the local cluster's workers, processes or threads, bytes per worker.
    Raises :class:`_Interrupted` (the cluster closed) after a Ctrl-C.
    """
    if not todo:
        return []
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    workers, processes, limit = local

    outcomes: list[SessionOutcome] = []
    with SigintFlag() as sigint:
        cluster = None
        client = None
        settings = dask.config.set(local_cluster_config() if scheduler is None else {})
        quiet = dask_silenced(scheduler is None)  # batch_interrupt.py
        quiet.__enter__()
        try:
            with sigint.ignored():
                if scheduler is None:
                    cluster = LocalCluster(
                        n_workers=min(workers, len(todo)),
                        threads_per_worker=1,
                        processes=processes,
                        dashboard_address=None,
                        # its metrics server on a free port: Dask's default 8787 taken (a
                        # user's dashboard, another cluster) printed a UserWarning
                        scheduler_kwargs={"dashboard_address": ":0"},
                        memory_limit=limit,
                    )
                try:
                    client = Client(
                        cluster if cluster is not None else scheduler,
                        timeout=HANDSHAKE_TIMEOUT_S,
                    )
                except (OSError, TimeoutError) as err:
                    raise CoopprocError(
                        f"scheduler {scheduler}: no Dask scheduler answered within "
                        f"{HANDSHAKE_TIMEOUT_S:g} s ({err})"
                    ) from err
            if cluster is not None and processes:
                client.register_plugin(quiet_workers())  # type: ignore[arg-type]
            futures = {
                client.submit(run_one, s, o, config, f, formats, pure=False): (s, o)
                for s, o, f in todo
            }
            pending = as_completed(futures)
            seen: set[object] = set()

            def report(future: Any) -> None:
                seen.add(future)
                try:
                    outcome = future.result()
                except Exception as err:  # a worker died or the task raised
                    s, o = futures[future]
                    outcome = failed_outcome(s, o, failure_line(client, err, s, limit))
                outcomes.append(outcome)
                if on_done is not None:
                    on_done(outcome)

            while not sigint.hit and not pending.is_empty():
                if not pending.has_ready():
                    time.sleep(POLL_S)
                    continue
                for future in pending.next_batch(block=False):
                    report(future)
            if sigint.hit:  # the sessions that finished meanwhile are reported too
                for future in futures:
                    if future not in seen and future.status == "finished":
                        report(future)
                with dask_silenced():
                    client.cancel([f for f in futures if f not in seen], force=True)
        finally:  # Dask's "still alive after 4 s, killing" on a loaded machine: not news
            with dask_silenced():
                if client is not None:
                    client.close()
                if cluster is not None:
                    cluster.close()
            settings.__exit__(None, None, None)
            quiet.__exit__(None, None, None)
        if sigint.hit:
            raise _Interrupted(outcomes)
    return outcomes


def _entry(
    session: Path, name: str, outcome: SessionOutcome, out_root: Path, started: str
) -> BatchEntry:
    """This call's batch.json entry of one session."""
    status = "skipped" if outcome.skipped else "processed" if outcome.ok else "failed"
    info = run_json(out_root / name) if outcome.ok else None
    when = str(info.get("start_time", started)) if info is not None else started
    return BatchEntry(str(session.resolve()), name, outcome.ok, outcome.error, status, when)


def check_scheduler(address: str) -> None:
    """Raise CoopprocError unless a Dask scheduler answers at ``address``, within seconds.

    A socket connect first (nothing there: refused at once, or no answer within
    CONNECT_TIMEOUT_S), then for tcp the scheduler's identity within HANDSHAKE_TIMEOUT_S
    (something else listening there never gives it); one line naming address and cause.
    """
    from distributed.comm import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return  # other transports: the client's own timeout decides
        host, port = parse_host_port(location, 8786)
    except ValueError as err:
        raise CoopprocError(
            f"scheduler {address}: not an address ({err}); expected tcp://host:port"
        ) from err
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
    except TimeoutError as err:
        cause = f"no answer within {CONNECT_TIMEOUT_S:g} s"
        raise CoopprocError(
            f"scheduler {address}: cannot connect ({cause}); is a Dask scheduler running there?"
        ) from err
    except OSError as err:
        raise CoopprocError(
            f"scheduler {address}: cannot connect ({os_cause(err)}); "
            "is a Dask scheduler running there?"
        ) from err
    if scheme == "tcp":  # tls needs the cluster's certificates: the client checks it
        with ThreadPoolExecutor(1) as pool:  # its own event loop, even under a running one
            problem = pool.submit(asyncio.run, _not_a_scheduler(address)).result()
        if problem:
            raise CoopprocError(f"scheduler {address}: {problem}")


async def _not_a_scheduler(address: str) -> str:
    """Why what answers at ``address`` is no Dask scheduler ("" when it is one)."""
    from distributed.comm import connect

    async def identity() -> object:
        comm = await connect(address, timeout=HANDSHAKE_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = await asyncio.wait_for(identity(), HANDSHAKE_TIMEOUT_S)
    except TimeoutError:
        return (
            "something listens there but is no Dask scheduler "
            f"(no reply within {HANDSHAKE_TIMEOUT_S:g} s)"
        )
    except Exception as err:  # any failure of the probe: the connection broke
        return f"no Dask scheduler answered ({type(err).__name__}: {err})"
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind == "Scheduler":
        return ""
    return f"a Dask {kind} answers there, not the scheduler" if kind else "no Dask scheduler"


def _now() -> str:
    return dt.datetime.now(dt.UTC).isoformat(timespec="seconds")
