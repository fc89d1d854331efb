"""The evaluation tables of ``coopproc report OUT --evaluate`` and of the HTML page.

One table per alignment (platform x method: 3-D, horizontal and vertical errors; the
relative change against Observed and the best value marked, as in Table 3), one table of
the fitted transforms per alignment other than ``none``, and one relative-error (RPE)
table per alignment and segment length. Rendered by :mod:`coopproc.report.formats` in
every format (terminal, CSV, Markdown, LaTeX, HTML). The numbers are recomputed from
``positions.csv`` (:mod:`coopproc.report.evaluation`, :mod:`coopproc.report.rpe`), so this
works on any finished run, one without ``evaluation.csv`` included.
"""

from __future__ import annotations

import dataclasses
import difflib
import html
from collections.abc import Sequence

import pandas as pd

from coopproc.errors import ConfigError
from coopproc.report.bootstrap import DEFAULT_LEVEL
from coopproc.report.evaluation import EVALUATION_COLUMNS, check_alignments
from coopproc.report.formats import Format, render_table
from coopproc.report.latex import LatexWidth
from coopproc.report.methods import position_methods
from coopproc.report.rpe import (
    DEFAULT_SEGMENTS_M,
    RPE_COLUMNS,
    check_segments,
    evaluation_and_rpe,
)
from coopproc.report.run_tables import RunTables
from coopproc.report.tables import METRIC_SPECS, MetricSpec, Table, position_table

__all__ = [
    "EVALUATION_DEFAULT",
    "RPE_DEFAULT",
    "TRANSFORM_METRICS",
    "evaluation_html",
    "evaluation_tables",
    "format_evaluation",
]

_AXIS_LABEL = {"east": "E", "north": "N", "up": "U"}
_SPECS: dict[str, MetricSpec] = {}
for _suffix, _tag in (("3d", "3D"), ("h", "H")):
    _SPECS.update(
        {
            f"rmse_{_suffix}": MetricSpec(f"RMSE {_tag}", "m"),
            f"mean_{_suffix}": MetricSpec(f"Mean {_tag}", "m"),
            f"median_{_suffix}": MetricSpec(f"Median {_tag}", "m"),
            f"std_{_suffix}": MetricSpec(f"Std {_tag}", "m"),
            f"min_{_suffix}": MetricSpec(f"Min {_tag}", "m", better=None),
            f"max_{_suffix}": MetricSpec(f"Max {_tag}", "m"),
        }
    )
for _axis, _tag in _AXIS_LABEL.items():
    _SPECS.update(
        {
            f"rms_{_axis}": MetricSpec(f"RMS {_tag}", "m"),
            f"mean_{_axis}": MetricSpec(f"Bias {_tag}", "m", better="absmin", signed=True),
            f"std_{_axis}": MetricSpec(f"Std {_tag}", "m"),
            f"min_{_axis}": MetricSpec(f"Min {_tag}", "m", better=None),
            f"max_{_axis}": MetricSpec(f"Max {_tag}", "m", better=None),
            f"absmax_{_axis}": MetricSpec(f"|Max| {_tag}", "m"),
        }
    )
_SPECS.update(
    {
        "align_scale": MetricSpec("Scale", "", 6, None),
        "align_roll_deg": MetricSpec("Roll", "deg", 4, None),
        "align_pitch_deg": MetricSpec("Pitch", "deg", 4, None),
        "align_yaw_deg": MetricSpec("Yaw", "deg", 4, None),
        "align_east": MetricSpec("Shift E", "m", 4, None),
        "align_north": MetricSpec("Shift N", "m", 4, None),
        "align_up": MetricSpec("Shift U", "m", 4, None),
        "segments": MetricSpec("Segments", "", 0, None),
        # report/evaluation_extra.py: coverage, along / cross-track
        "coverage": MetricSpec("Coverage", "", 3, "max"),
        "rms_along": MetricSpec("RMS along", "m"),
        "rms_cross": MetricSpec("RMS cross", "m"),
        "mean_along": MetricSpec("Bias along", "m", better="absmin", signed=True),
        "mean_cross": MetricSpec("Bias cross", "m", better="absmin", signed=True),
        "absmax_along": MetricSpec("|Max| along", "m"),
        "absmax_cross": MetricSpec("|Max| cross", "m"),
        "rmse_m": MetricSpec("RMSE", "m"),
        "mean_m": MetricSpec("Mean", "m"),
        "median_m": MetricSpec("Median", "m"),
        "std_m": MetricSpec("Std", "m"),
        "min_m": MetricSpec("Min", "m", better=None),
        "max_m": MetricSpec("Max", "m"),
        "mean_pct": MetricSpec("Mean", "%", 2),
        "max_pct": MetricSpec("Max", "%", 2),
    }
)
for _name, _spec in _SPECS.items():  # shown like the other statistics (tables.METRIC_SPECS)
    METRIC_SPECS.setdefault(_name, _spec)

#: Columns shown by default: the evaluation tables, the RPE tables, the transform tables.
EVALUATION_DEFAULT = (
    "rmse_3d",
    "mean_3d",
    "std_3d",
    "max_3d",
    "rmse_h",
    "rms_along",
    "rms_cross",
    "rms_up",
    "coverage",
    "n",
)
RPE_DEFAULT = ("segments", "rmse_m", "mean_m", "max_m", "mean_pct")
TRANSFORM_METRICS = tuple(c for c in EVALUATION_COLUMNS if c.startswith("align_"))
#: The HTML page shows more columns.
_HTML_EVALUATION = (
    "rmse_3d",
    "mean_3d",
    "median_3d",
    "std_3d",
    "max_3d",
    "rmse_h",
    "rms_east",
    "rms_north",
    "rms_up",
    "absmax_up",
    "n",
)
_HTML_RPE = ("segments", "rmse_m", "mean_m", "median_m", "max_m", "mean_pct", "max_pct")


def _check_metrics(names: Sequence[str]) -> None:
    known = [c for c in (*EVALUATION_COLUMNS, *RPE_COLUMNS) if c in METRIC_SPECS or c == "n"]
    for name in names:
        if name not in known:
            near = difflib.get_close_matches(name, known, n=1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise ConfigError(
                f"unknown evaluation metric {name!r}{hint} (known: {', '.join(known)})"
            )


def _table(
    frame: pd.DataFrame,
    columns: Sequence[str],
    platforms: Sequence[str] | None,
    order: Sequence[str],
    *,
    key: str,
    title: str,
    with_change: bool = True,
    level: float | None = None,
) -> Table:
    """A platform x method table of ``frame``'s rows (Table 3's layout and markings;
    ``level``: with the intervals of its ``<m>_lo`` / ``<m>_hi`` columns)."""
    table = position_table(frame, columns, platforms, order, level=level)
    return dataclasses.replace(
        table, key=key, title=title, has_change=with_change and table.has_change
    )


def evaluation_tables(
    run: RunTables,
    *,
    align: Sequence[str] = ("none",),
    segments_m: Sequence[float] = DEFAULT_SEGMENTS_M,
    metrics: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    evaluation_columns: Sequence[str] = EVALUATION_DEFAULT,
    rpe_columns: Sequence[str] = RPE_DEFAULT,
    stored: bool = False,
) -> list[Table]:
    """The evaluation, transform and RPE tables of ``run``, recomputed from its positions.

    ``align``: alignments (a block of tables each); ``segments_m``: RPE segment lengths
    (none: no RPE table); ``metrics``: the columns of every table (names a table does not
    have are skipped there; the ``align_*`` ones go to the transform table only);
    ``platforms``: rows to keep. Unknown alignments, lengths,
    metrics or platforms raise ConfigError. Tables without rows or columns are left out.
    ``stored``: take the run's own ``evaluation.csv`` / ``rpe.csv`` (no alignment, the
    default lengths) when it has them instead of recomputing them (a day of positions:
    seconds).
    """
    try:
        align = check_alignments(align)
        lengths = check_segments(segments_m)
    except ValueError as err:
        raise ConfigError(str(err)) from err
    if metrics is not None:
        _check_metrics(metrics)
    methods = position_methods(run)
    order = ("nav", *methods)
    as_run = tuple(align) == ("none",) and tuple(lengths) == tuple(DEFAULT_SEGMENTS_M)
    if stored and as_run and run.evaluation is not None and run.rpe is not None:
        ev, errors = run.evaluation, run.rpe
    else:
        ev, errors = evaluation_and_rpe(run.positions, lengths, align, methods)  # one pass
    tables: list[Table] = []
    for kind in align:
        rows = ev[ev["alignment"] == kind]
        title = f"Trajectory errors per platform and method, alignment {kind}"
        cols = [m for m in metrics if m not in TRANSFORM_METRICS] if metrics else evaluation_columns
        tables.append(
            _table(
                rows,
                cols,
                platforms,
                order,
                key=f"evaluation_{kind}",
                title=title,
                level=DEFAULT_LEVEL,  # evaluation.csv's intervals (report/evaluation_extra.py)
            )
        )
        if kind != "none":
            tables.append(
                _table(
                    rows,
                    [m for m in metrics if m in TRANSFORM_METRICS]
                    if metrics
                    else TRANSFORM_METRICS,
                    platforms,
                    order,
                    key=f"transform_{kind}",
                    title=f"Fitted transform (estimate onto reference), alignment {kind}",
                    with_change=False,
                )
            )
        for length in lengths:
            block = errors[(errors["alignment"] == kind) & (errors["segment_m"] == length)]
            tables.append(
                _table(
                    block,
                    metrics or rpe_columns,
                    platforms,
                    order,
                    key=f"rpe_{kind}_{length:g}m",
                    title=f"Relative error over {length:g} m of travel, alignment {kind}",
                )
            )
    return [t for t in tables if t.metrics and t.rows]


def format_evaluation(
    run: RunTables,
    fmt: Format,
    *,
    align: Sequence[str] = ("none",),
    segments_m: Sequence[float] = DEFAULT_SEGMENTS_M,
    metrics: Sequence[str] | None = None,
    platforms: Sequence[str] | None = None,
    change: bool = True,
    latex_width: LatexWidth = "single",
) -> str:
    """The tables of :func:`evaluation_tables` in one format, separated by a blank line
    (``change``, ``latex_width``: as :func:`coopproc.report.formats.render_table`)."""
    tables = evaluation_tables(
        run, align=align, segments_m=segments_m, metrics=metrics, platforms=platforms
    )
    return "\n".join(render_table(t, fmt, change=change, latex_width=latex_width) for t in tables)


def evaluation_html(run: RunTables) -> str:
    """The "Evaluation" section of report.html: no alignment, RPE over 10, 50 and 100 m,
    recomputed from the positions (what ``evaluation.csv`` and ``rpe.csv`` hold), so an
    older run directory without those files gets the section too."""
    if not len(run.positions):
        return ""
    tables = evaluation_tables(
        run, evaluation_columns=_HTML_EVALUATION, rpe_columns=_HTML_RPE, stored=True
    )
    if not tables:
        return ""
    note = (
        "3-D, horizontal (H) and vertical (U) errors against the reference rows of "
        "positions.csv, and the relative error per travelled distance (KITTI-style); "
        "definitions in docs/report.md. Other alignments: "
        "coopproc report OUT --evaluate --align se2|yaw|se3|sim3."
    )
    parts = ["<h2>Evaluation</h2>", f'<p class="note">{html.escape(note)}</p>']
    parts += [render_table(t, "html") for t in tables]
    return "\n".join(parts)
