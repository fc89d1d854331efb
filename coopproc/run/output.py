"""Write a finished run to its output directory (DATA.md "Output"), atomically.

CSV tables with fixed columns and float format (byte-identical for the same inputs and
config; the per-epoch ones as Parquet with ``[run] format = "parquet"``),
``nlos_scores.csv``, ``figures/``, ``report.html`` and ``run.json``.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import hashlib
import json
import platform
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from coopproc import __version__
from coopproc.checks.clock import clock_facts
from coopproc.io.injected import session_injected
from coopproc.io.outdir import atomic_output_dir, write_csv
from coopproc.io.parquet import require_pyarrow, write_parquet
from coopproc.memory import release_freed_memory
from coopproc.model import FloatArray, Session
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.comparisons import comparisons
from coopproc.report.consistency import with_consistency
from coopproc.report.figures import FigurePage, figure_pages, write_figures
from coopproc.report.html import write_html
from coopproc.report.injected import injected_scores
from coopproc.report.methods import position_methods_of, range_methods_of
from coopproc.report.pages import FigureOptions
from coopproc.report.rpe import evaluation_and_rpe
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import RUN_EXTENSION_FILES, RUN_FILES, table_file_name
from coopproc.report.table_specs import run_labels
from coopproc.run.calibration_summary import calibration_facts
from coopproc.run.config import RunConfig
from coopproc.run.outages import OutageOutput, OutageReport
from coopproc.run.pipeline_output import PipelineOutput
from coopproc.stages.registry import declared_labels

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["RunFiles", "hash_inputs", "run_tables", "sha256_of", "write_run"]


@dataclass(frozen=True)
class RunFiles:
    """What was written."""

    out_dir: Path
    tables: tuple[Path, ...]
    figures: tuple[Path, ...]
    html: Path | None
    run_json: Path
    #: notes of the writing, e.g. what the figures' page cap left out (also in run.json)
    notes: tuple[str, ...] = ()


def sha256_of(path: Path) -> str:
    """SHA-256 of a file's bytes, hex."""
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def hash_inputs(paths: Sequence[Path]) -> Future[dict[Path, str]]:
    """:func:`sha256_of` every input file (run.json ``inputs``) in a thread of its own,
    begun when the session is read: hashlib releases the GIL, so the digests (about 2 s
    for the 1.3 GB of a day of 10 platforms, issue 11) take a CPU the run's single-
    threaded steps leave idle instead of wall time at the end. ``write_run`` takes the
    result (``input_sha256``)."""
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sha256")
    future = pool.submit(lambda: {p: sha256_of(p) for p in paths})
    pool.shutdown(wait=False)  # the thread ends with its one task
    return future


def run_tables(
    output: PipelineOutput, info: Mapping[str, Any], injected: pd.DataFrame | None = None
) -> RunTables:
    """The reporters' view of a run, from the in-memory result (``injected``: the
    ``injected_scores.csv`` table of an injected session)."""
    r = output.result
    methods = (output.methods or {}).get("positions")  # evaluation.csv / rpe.csv row order
    # both from one pass over the aligned tracks (a day of positions: seconds)
    evaluated, relative = evaluation_and_rpe(r.positions, methods=methods)
    # NIS of the fusion's range innovations, NEES of the INS states (report/consistency.py)
    evaluated = with_consistency(evaluated, r.range_weights, r.states)
    return RunTables(
        ranges=r.ranges,
        di=r.di,
        nlos_events=r.nlos_events,
        nlos_estimates=r.nlos_estimates,
        positions=r.positions,
        metrics=r.metrics,
        position_metrics=r.position_metrics,
        nlos_scores=output.nlos_scores,
        nlos_event_scores=output.nlos_event_scores,
        info=dict(info),
        injected_scores=injected,
        evaluation=evaluated,
        rpe=relative,
        states=r.states,
        dr_states=r.dr_states,
        range_weights=r.range_weights,
        lsq_quality=r.lsq_quality,
        outages=outages.table if (outages := _outage_report(output)) is not None else None,
        comparisons=comparisons(
            r.ranges,
            r.positions,
            (output.methods or {}).get("ranges") or range_methods_of(r.ranges),
            ("nav", *(methods or position_methods_of(r.positions))),
            DEFAULT_LEVEL,
        ),
    )


def write_run(
    output: PipelineOutput,
    session: Session,
    config: RunConfig,
    out_dir: str | Path,
    *,
    force: bool = False,
    figure_formats: Sequence[str] = ("png",),
    started: dt.datetime,
    started_clock: float | None = None,
    summary: Mapping[str, Any] | None = None,
    figure_options: FigureOptions | None = None,
    progress: Callable[[str], None] | None = None,
    timings_before: Mapping[str, float] | None = None,
    timings_after: Mapping[str, float] | None = None,
    input_sha256: Future[dict[Path, str]] | None = None,
    nav_gaps: Mapping[str, FloatArray] | None = None,
) -> RunFiles:
    """Write every output of a run into ``out_dir`` (atomically; see coopproc.io.outdir).

    ``config.run.format`` "parquet": the per-epoch tables as Parquet (needs pyarrow).
    ``progress`` is called as each writing phase starts ("write tables", "figures",
    "html"). run.json ``timings_s``: ``timings_before`` (e.g. reading), the chain's
    steps, ``timings_after`` (e.g. the summary), the writing phases, and ``other`` (the
    rest of the wall time since ``started``: imports, checks, run.json), so that they add
    up to ``duration_s``. ``started_clock``: ``time.perf_counter()`` read with
    ``started``: ``duration_s`` is then measured on that monotonic clock, like the phases
    (the system clock may be stepped during a long run: a VM's was, by 9 s, in a day's
    run); None: from the system clock. ``input_sha256``: :func:`hash_inputs` of
    ``session.inputs`` begun earlier (None: hashed here). ``nav_gaps``: where each
    platform's navigation is missing (:func:`~coopproc.checks.coverage.nav_gap_spans` of
    the session before its samples were let go of), run.json ``nav_gaps``.
    """
    phase = progress or (lambda label: None)
    digests = {} if input_sha256 is None else input_sha256.result()
    if figure_options is None:  # e.g. coopproc batch: the configuration's page cap
        figure_options = FigureOptions(max_pages=config.run.max_pages)
    timings: dict[str, float] = {
        **(timings_before or {}),
        **output.timings_s,
        **(timings_after or {}),
    }
    clock = time.perf_counter
    if config.run.format == "parquet":
        require_pyarrow()
    info: dict[str, Any] = {
        "coopproc_version": __version__,
        "python": platform.python_version(),
        "session": {
            "name": session.name,
            "path": str(session.root),
            # the time base and geodetic origin, for `coopproc export` (GPS times, lat/lon)
            "time_base": session.config.time_base,
            "gps_week": session.config.gps_week,
            "origin_llh": list(session.origin_llh)
            if session.config.origin_llh is not None or any(session.origin_llh)
            else None,
            # fixed platforms' ENU positions: the figures mark them
            "anchors": {
                p.id: list(p.position_enu_m)
                for p in session.platforms.values()
                if p.role == "anchor" and p.position_enu_m is not None
            },
        },
        "config": config.to_dict(),
        "pipeline": [
            {"step": s.label, "inputs": list(s.inputs), "outputs": list(s.outputs)}
            | ({"reason": s.reason} if s.reason else {})
            for s in output.chain
        ],
        "methods": {k: list(v) for k, v in (output.methods or {}).items()},
        # the display names the registry declares for them: the report shows these
        "method_labels": declared_labels(
            dict.fromkeys(m for names in (output.methods or {}).values() for m in names)
        ),
        "inputs": [
            {"file": _relative(p, session.root), "sha256": digests.get(p) or sha256_of(p)}
            for p in session.inputs
        ],
        "notes": list(session.notes),
        "sigma": {p: {"sigma_m": s, "source": src} for p, (s, src) in output.sigma.items()},
        "calibration": calibration_facts(output),
        "timings_s": timings,
        "start_time": started.isoformat(timespec="seconds"),
    }
    # where the navigation is missing, per platform: the figures shade it as such
    info["nav_gaps"] = {
        pid: [[round(float(a), 6), round(float(b), 6)] for a, b in spans]
        for pid, spans in (nav_gaps or {}).items()
    }
    if session.clock is not None:  # the clock offsets estimated (checks.clock)
        info["clock"] = clock_facts(session.clock)
    outages = _outage_report(output)
    if outages is not None:  # [run] outages: the windows and the ranges withheld
        info["outages"] = outages.facts()
    # a session made by `coopproc inject`: the methods scored against its injected.csv
    injected = session_injected(session.root)
    scores = None
    if injected is not None:
        scores = injected_scores(injected[1], output.result.nlos_events, output.nlos_methods)
        info["injected"] = {"file": injected[0].name, "sha256": sha256_of(injected[0])}
    with (
        atomic_output_dir(out_dir, force=force, protect=[session.root, *session.inputs]) as tmp,
        run_labels(info),  # the figures and report.html name the methods as run.json does
    ):
        # the same list of files and columns that `coopproc report` reads back
        phase("write tables")
        since = clock()
        run = run_tables(output, info, scores)
        tables = [
            _write_table(getattr(run, attr), tmp, name, columns, config.run.format)
            for name, attr, columns, _required in RUN_FILES
        ]
        tables += [
            _write_table(getattr(run, attr), tmp, name, columns, config.run.format)
            for name, attr, columns, _required in RUN_EXTENSION_FILES
            if getattr(run, attr) is not None
        ]
        timings["write tables"] = clock() - since
        figures: list[Path] = []
        pages: list[FigurePage] | None = None
        info["summary"] = dict(summary or {})
        if config.run.figures:
            phase("figures")
            since = clock()
            cap_notes: list[str] = []  # what the figures' page cap left out
            pages = list(figure_pages(run, figure_options))  # listed once, for report.html too
            # building the panels passes through about 1 GB at a day (issue 11): returned
            # before the workers fork, not inherited by them (the phase's start returned
            # the writers' buffers and the samples the pipeline let go)
            release_freed_memory()
            figures = write_figures(
                run,
                tmp / "figures",
                formats=figure_formats,
                options=figure_options,
                notes=cap_notes,
                pages=pages,
            )
            info["notes"] = [*info["notes"], *cap_notes]
            timings["figures"] = clock() - since
            info["figures"] = [str(p.relative_to(tmp)) for p in figures]
        # report.html also without figures (--no-figures): the page says it has none
        phase("html")
        since = clock()
        # the tables already made (evaluation and RPE are not computed again)
        html = write_html(
            tmp,
            dataclasses.replace(run, info=dict(info)),
            options=figure_options,
            figures=config.run.figures,
            pages=pages,
        )
        timings["html"] = clock() - since
        info["figures"] = [str(p.relative_to(tmp)) for p in figures]
        if started_clock is not None:
            info["duration_s"] = round(clock() - started_clock, 3)
        else:
            info["duration_s"] = round((dt.datetime.now(dt.UTC) - started).total_seconds(), 3)
        timings["other"] = max(info["duration_s"] - sum(timings.values()), 0.0)
        info["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
        run_json = tmp / "run.json"
        run_json.write_text(json.dumps(info, indent=2, default=_json_default) + "\n")
    final = Path(out_dir)
    return RunFiles(
        out_dir=final,
        tables=tuple(final / p.name for p in tables),
        figures=tuple(final / p.relative_to(tmp) for p in figures),
        html=final / html.name,
        run_json=final / "run.json",
        notes=tuple(info["notes"][len(session.notes) :]),
    )


def _write_table(
    frame: pd.DataFrame, out: Path, name: str, columns: Sequence[str], table_format: str
) -> Path:
    """Table ``name`` ("positions.csv") into ``out``: CSV, or Parquet for a per-epoch
    table when ``table_format`` is "parquet" (report.rundir.PARQUET_TABLES)."""
    path = out / table_file_name(name, table_format)
    if path.suffix == ".parquet":
        return write_parquet(frame, path, columns)
    return write_csv(frame, path, columns)


def _outage_report(output: PipelineOutput) -> OutageReport | None:
    """The outage windows' report of a run with [run] outages (coopproc.run.outages)."""
    return output.outages if isinstance(output, OutageOutput) else None


def _relative(path: Path, root: Path) -> str:
    base = root if root.is_dir() else root.parent
    try:
        return str(path.resolve().relative_to(base.resolve()))
    except ValueError:
        return str(path)


def _json_default(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serializable: {type(value).__name__}")
