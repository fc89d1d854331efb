"""Run the stage chain of ``coopproc run`` on a session (:mod:`coopproc.run.chain`).

The default chain is paper 000's processing (figure 5):

1. cooperative fusion with the observed ranges (the CP solution, paper 000 sec. 3.1.1);
2. DI smoothing, distance filtering, NLOS detection and estimation, DI- and RN-Based
   (paper 000 sec. 3.1-3.3), fed with the CP solution of step 1 (two passes: the whole
   session is fused first, then the ranges are processed; the CP increments are those of
   the causal forward filter unless ``[run] cp_solution = "smoothed"``);
3. fusion again with each processed range set (``rn``, ``di``);
4. positions of every method against the reference, and the statistics of Tables 2 and 3.

``[pipeline]`` changes which range methods and position estimators run; this module runs
whatever :func:`coopproc.run.session_chain.resolve_session` gives, in order, and builds
the output tables from the stages' products. It reads no files and prints nothing;
``progress`` is called with each step's label so that the CLI can show where it is.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from collections.abc import Set as AbstractSet
from typing import Any, Literal

import numpy as np
import pandas as pd

from coopproc.errors import StageError
from coopproc.memory import Held
from coopproc.model import (
    DI_COLUMNS,
    NLOS_ESTIMATE_COLUMNS,
    NLOS_EVENT_COLUMNS,
    FloatArray,
    Result,
    Session,
)
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.run.chain import Step
from coopproc.run.concurrent_steps import group_label, group_steps, run_concurrently, workers
from coopproc.run.config import RunConfig
from coopproc.run.declared import DeclaredDrifts, check_drifts, declared_quality
from coopproc.run.declared_sigma import check_declared_sigma, with_sigma
from coopproc.run.implausible import implausible_methods
from coopproc.run.ins import states_table
from coopproc.run.outages import run_with_outages
from coopproc.run.pipeline_output import PipelineOutput
from coopproc.run.positions_table import PositionSamples, positions_table
from coopproc.run.range_sets import ranges_for, row_sigma
from coopproc.run.scoring import score_tables
from coopproc.run.session_chain import resolve_session
from coopproc.run.tags import tag_rows, widen
from coopproc.stages.anchors.anchor_lsq import lsq_quality_of
from coopproc.stages.base import PositionInput, PositionProduct, RangeInput, RangeProduct
from coopproc.stages.fusion.dr_quality import dead_reckoning_quality
from coopproc.stages.fusion.dr_states import dr_states_of
from coopproc.stages.fusion.range_weights import range_weights_of
from coopproc.stages.ranging.table import observed_table
from coopproc.stages.registry import (
    POSITION_STAGES,
    RANGE_STAGES,
    nlos_source,
    primary_method,
    range_stage_of,
)

__all__ = ["run_pipeline"]


def run_pipeline(
    session: Session | Held[Session],
    config: RunConfig,
    progress: Callable[[str], None] | None = None,
) -> PipelineOutput:
    """Run the configured stage chain on a session (see the module docstring).

    A session handed over in a :class:`~coopproc.memory.Held` box, with no other
    reference kept, is let go of as it is spent: once positions.csv's table has read the
    navigation and reference, nothing reads the session's samples (nav, reference, range
    rows), and the box then holds the session without them
    (:meth:`~coopproc.model.Session.without_samples`), freed before the rest of the
    metrics, the writing and the figures (about 1.1 GB at a day of 10 platforms, issue
    11). A plain session is only read."""
    held = session if isinstance(session, Held) else None
    session = session.value if isinstance(session, Held) else session
    if config.run.outages:  # ranges withheld in the windows, listed again (run.outages)
        return run_with_outages(session, config, run_pipeline, progress)
    step_label = progress or (lambda label: None)
    timings: dict[str, float] = {}
    # the declared [uwb] sigma against the ranges and the DR, before anything uses it
    sigma_checked = check_declared_sigma(session)
    session = with_sigma(session, sigma_checked)

    @contextlib.contextmanager
    def timed(label: str) -> Iterator[None]:
        step_label(label)
        start = time.perf_counter()
        yield
        timings[label] = round(time.perf_counter() - start, 3)

    # the session's families (tags, odometers, anchors, IMUs, GPS) and [pipeline], in one
    # place (run.session_chain; what `coopproc config --session` shows)
    chain = resolve_session(config, session)
    session, dr_session, pipeline, steps = (
        chain.session,
        chain.dr_session,
        chain.pipeline,
        chain.steps,
    )
    tag_notes = list(chain.notes)
    del chain  # it holds the sessions, which are let go of when spent (held)
    if sigma_checked is not None and sigma_checked.note is not None:
        tag_notes.insert(0, sigma_checked.note)
    for step in steps:
        check = POSITION_STAGES[step.stage].check if step.kind == "positions" else None
        if check is not None:
            check(session)
    output: Literal["ranges", "nav"] = config.run.positions_at
    base = observed_table(session)
    dr_rows = ~tag_rows(session, base["pair"]) if dr_session is not session else None
    dr_base = base if dr_rows is None else base[dr_rows].reset_index(drop=True)
    sigma_by_row = row_sigma(session, base)
    range_sets = {"observed": session.ranges.frame[["time", "from", "to", "range", "sigma"]]}
    unsmoothed: set[str] = set()  # a smoothed method's range set that is not (fusion_values)
    columns: dict[str, FloatArray] = {}
    range_products: list[RangeProduct] = []
    products: dict[str, PositionProduct] = {}
    cp_product: PositionProduct | None = None
    drifts_checked: DeclaredDrifts | None = None
    # independent position steps (fusion (rn), fusion (di)) two at a time (concurrent_steps)
    done = 0
    for group in group_steps(steps, workers(config.run.parallel_fusion, len(base))):
        done += len(group)
        with timed(group_label(group)):
            step = group[0]
            if step.kind == "ranges":
                product = _run_range_step(step, dr_session, dr_base, config, cp_product)
                if dr_rows is not None:
                    product = widen(product, dr_rows)
                range_products.append(product)
                for method in step.methods:
                    columns[method] = product.values[method]
                    fused = product.fusion_values.get(method)
                    if fused is not None:  # its fusion's input: not smoothed over time
                        unsmoothed.add(method)
                    range_sets[method] = ranges_for(
                        base, columns[method] if fused is None else fused, sigma_by_row
                    )
                cp_product = _drop_spent(steps[done:], range_sets, products, cp_product)
                continue
            results = run_concurrently(
                [
                    functools.partial(
                        _run_position_step,
                        s,
                        session,
                        dr_session,
                        range_sets,
                        products,
                        config,
                        unsmoothed,
                    )
                    for s in group
                ],
                [s.label for s in group],
            )
            for step, position_product in zip(group, results, strict=True):
                products[step.methods[0]] = position_product
                if "cp" in step.outputs:
                    cp_product = position_product
            del results, position_product
            cp_step = next((s for s in group if "cp" in s.outputs), None)
            if drifts_checked is None and cp_step is not None and cp_product is not None:
                params = config.params_for(POSITION_STAGES[cp_step.stage].section)
                drifts_checked, session, dr_session, redo = check_drifts(
                    session, dr_session, cp_product.positions, params
                )  # the declared drifts against the CP solution (run.declared)
                tag_notes += list(drifts_checked.notes)
                if redo:  # its model used a replaced figure: run again with the estimate
                    products[cp_step.methods[0]] = cp_product = _run_position_step(
                        cp_step, session, dr_session, range_sets, products, config
                    )
            cp_product = _drop_spent(steps[done:], range_sets, products, cp_product)

    # ranges.csv keeps the config's column order whatever order the steps ran in
    columns = {m: columns[m] for m in pipeline.ranges}
    del range_sets, sigma_by_row, dr_base  # spent once the position steps have run
    with timed("metrics"):
        # the dead reckoning against the CP solution first: positions.csv's table then
        # takes the products' trajectories, freeing each platform's once copied in
        cp_positions = cp_product or products.get("observed")
        del cp_product
        dr_quality = (
            {} if cp_positions is None else dead_reckoning_quality(session, cp_positions.positions)
        )
        if drifts_checked is not None and drifts_checked.replaced:  # declared in brackets
            dr_quality = declared_quality(dr_quality, drifts_checked.contradicted)
        del cp_positions
        states = states_table(session, products)
        dr_states = dr_states_of(products)
        range_weights = range_weights_of(products)
        lsq_quality = lsq_quality_of(products)
        implausible = implausible_methods(session, products)  # before the table takes them
        # each product's frame is in the table now: not held twice
        for method, weighed in list(products.items()):
            if weighed.range_weights is not None:
                products[method] = dataclasses.replace(weighed, range_weights=None)
        table = _range_table(base, columns, range_products)
        del base  # the table holds its columns
        # positions.csv's table reads the navigation and reference it takes now; the rest
        # reads the tables: the session lets go of its samples before the table is built,
        # and the table of each platform's once its rows are written (issue 11)
        samples = PositionSamples.of(session, output)
        if held is not None:
            session = dr_session = session.without_samples()
            held.replace(session)
        positions = positions_table(samples, products, output, release=True)
        del samples
        sigma = {p: s for prod in range_products for p, s in prod.sigma.items()}
        # true NLOS is labelled against the declared sigma (or, without one, the robust
        # spread of observed - reference), never against what the detector estimated
        declared = session.config.uwb_sigma_m
        label_sigma = {} if declared is None else {p: float(declared) for p in sigma}
        events = _concat_or_empty([p.nlos_events for p in range_products], NLOS_EVENT_COLUMNS)
        nlos_methods = tuple(m for m in columns if any(m in p.nlos for p in range_products))
        scores, event_scores, outliers = score_tables(
            table, events, label_sigma, nlos_methods, range_weights, tuple(products),
            range_products,
        )  # fmt: skip
        di = next((p.di for p in range_products if p.di is not None), None)
        result = Result(
            ranges=table,
            di=di if di is not None else pd.DataFrame(columns=list(DI_COLUMNS)),
            nlos_events=events,
            nlos_estimates=_concat_or_empty(
                [p.nlos_estimates for p in range_products], NLOS_ESTIMATE_COLUMNS
            ),
            positions=positions,
            # with the 95 % block-bootstrap intervals (report/intervals.py)
            metrics=distance_metrics(table, methods=("observed", *columns), level=DEFAULT_LEVEL),
            position_metrics=position_metrics(
                positions, methods=tuple(products), level=DEFAULT_LEVEL
            ),
            states=states,
            dr_states=dr_states,
            range_weights=range_weights,
            lsq_quality=lsq_quality,
        )
    return PipelineOutput(
        result=result,
        nlos_scores=scores,
        nlos_event_scores=event_scores,
        timings_s=timings,
        sigma=sigma,
        ranging_calibration={k: v for p in range_products for k, v in p.calibration.items()},
        fusion_calibration={
            m: p.calibration for m, p in products.items() if p.calibration is not None
        },
        dr_quality=dr_quality,
        notes=tuple(dict.fromkeys((*tag_notes, *(n for p in products.values() for n in p.notes)))),
        chain=steps,
        methods={
            "ranges": ("observed", *columns),
            "positions": tuple(products),
            "nlos": nlos_methods,
            "primary": tuple(m for m in [primary_method(columns)] if m is not None),
        },
        nlos_methods=nlos_methods,
        fusion_outlier_scores=outliers,
        implausible=implausible,
        declared_sigma=sigma_checked,
    )


def _drop_spent(
    later: Sequence[Step],
    range_sets: dict[str, pd.DataFrame],
    products: dict[str, PositionProduct],
    cp_product: PositionProduct | None,
) -> PositionProduct | None:
    """Free what no ``later`` step reads (a day's range set or CP solution is hundreds of
    MB): a processed range set after its last position step, the CP solution (causal and
    smoothed) after the last range step. Returns the CP product, without ``cp`` then.

    A day's CP solution is about 0.43 GB: it is freed once the caller rebinds its CP
    product, and the next phase's start gives its pages back to the system (memory.py).
    """
    wanted = {s.range_set for s in later if s.kind == "positions"}
    for name in [n for n in range_sets if n != "observed" and n not in wanted]:
        del range_sets[name]
    if cp_product is None or cp_product.cp is None or any(s.kind == "ranges" for s in later):
        return cp_product
    spent = dataclasses.replace(cp_product, cp=None, cp_left_out=None)
    for method, product in products.items():
        if product is cp_product:
            products[method] = spent
    return spent


def _run_position_step(
    step: Step,
    session: Session,
    dr_session: Session,
    range_sets: Mapping[str, pd.DataFrame],
    products: Mapping[str, PositionProduct],
    config: RunConfig,
    unsmoothed: AbstractSet[str] = frozenset(),
) -> PositionProduct:
    stage = POSITION_STAGES[step.stage]
    assert step.range_set is not None
    observed = None
    if stage.needs_observed and step.range_set != "observed":
        observed = products[stage.method("observed")]
    own = session if stage.uwb_only else dr_session
    producer = range_stage_of(step.range_set)
    position_input = PositionInput(
        own,
        step.range_set,
        own.ranges.frame[list(range_sets["observed"].columns)]
        if step.range_set == "observed" and own is not session
        else range_sets[step.range_set],
        config.run.positions_at,
        observed=observed,
        want_cp="cp" in step.outputs,
        smoothed=producer is not None
        and step.range_set in producer.smoothed
        and step.range_set not in unsmoothed,
    )
    return stage.run(position_input, config.params_for(stage.section))


def _run_range_step(
    step: Step,
    session: Session,
    base: pd.DataFrame,
    config: RunConfig,
    cp_product: PositionProduct | None,
) -> RangeProduct:
    stage = RANGE_STAGES[step.stage]
    cp = None
    dr_states: pd.DataFrame | None = None
    if stage.needs_cp:
        assert cp_product is not None and cp_product.cp is not None  # chain.resolve
        forward, smoothed = cp_product.cp
        cp = forward if config.run.cp_solution == "forward" else smoothed
        dr_states = (  # its DR states alike (the causal filter's: dr_corrected.py)
            cp_product.dr_states_forward if cp is forward else cp_product.dr_states
        )
    # the leave-pair-out solutions are causal: with cp_solution "smoothed", paper 000's
    left_out = (
        cp_product.cp_left_out
        if cp_product is not None and config.run.cp_solution == "forward"
        else None
    )
    inp = RangeInput(session, base, cp, left_out, dr_states)
    product = stage.run(inp, config.params_for(stage.section), step.methods)
    for method in step.methods:
        values = product.values.get(method)
        if values is None or np.shape(values) != (len(base),):
            raise StageError(
                f"{stage.name}: method '{method}' did not give one distance per range row"
            )
    return product


def _range_table(
    base: pd.DataFrame, columns: Mapping[str, FloatArray], products: list[RangeProduct]
) -> pd.DataFrame:
    """ranges.csv: ``time, pair, observed, <methods>, reference, nlos_flag, nlos_estimate,
    outlier``.

    The NLOS columns come from the method a range processor declares primary (the DI
    method, DATA.md; :func:`~coopproc.stages.registry.nlos_source`), or, without it, from
    the first method of the chain that detects NLOS; 0 where none does.
    """
    nlos = {m: fe for p in products for m, fe in p.nlos.items()}
    source = nlos_source(m for m in columns if m in nlos)
    if source is None:
        flag, estimate = np.zeros(len(base), dtype=np.int64), np.zeros(len(base))
    else:
        flag, estimate = nlos[source]
    data: dict[str, Any] = {c: base[c] for c in ("time", "pair", "observed")}
    data.update(columns)
    data["reference"] = base["reference"].to_numpy()
    data["nlos_flag"] = np.asarray(flag, dtype=np.int64)
    data["nlos_estimate"] = np.asarray(estimate, dtype=np.float64)
    # gross outliers rejected by any range processor (outliers.py), 0 where none ran
    outlier = np.zeros(len(base), dtype=np.int64)
    for p in products:
        if p.outlier is not None:
            outlier |= np.asarray(p.outlier, dtype=np.int64)
    data["outlier"] = outlier
    # the columns as they are (no copy: a day's table is ~270 MB, held once)
    return pd.DataFrame(data, copy=False)


def _concat_or_empty(frames: list[pd.DataFrame | None], columns: tuple[str, ...]) -> pd.DataFrame:
    present = [f for f in frames if f is not None]
    if not present:
        return pd.DataFrame(columns=list(columns))
    return pd.concat(present, ignore_index=True) if len(present) > 1 else present[0]
