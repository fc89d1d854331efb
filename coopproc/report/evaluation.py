"""Trajectory evaluation beyond Table 3: 3-D, horizontal and per-axis errors, optionally
after aligning each estimate onto the reference (``evaluation.csv``; evo's APE and more).

Pure functions of ``positions.csv`` (``time, platform, method, east, north, up, error_h``,
with the reference trajectory as the rows of method ``reference``); nothing is read,
written or printed. The definitions (restated in docs/report.md, "Evaluation"):

- **Epochs**: a method's rows with an ``error_h`` (the contract's "has a reference") and
  finite east/north/up, paired with the ``reference`` rows of the same platform at the
  same time (linearly interpolated between reference rows when the times differ, never
  across a gap of the reference rows: :func:`coopproc.model.gap_limit_s`). ``n`` counts
  them; without alignment they are the epochs of ``position_metrics.csv``.
- **Error** of epoch i: ``d_i = T(p_i) - q_i`` (east, north, up), ``p_i`` the method's
  position, ``q_i`` the reference, ``T`` the fitted alignment
  (:mod:`coopproc.report.alignment`; identity for ``none``).
- **3-D** ``e_i = |d_i|``, **horizontal** ``h_i = |(d_e, d_n)|``: ``rmse`` (population,
  sqrt of the mean square), ``mean``, ``median``, ``std`` (population, divisor n: numpy's
  and evo's), ``min``, ``max`` of the norm. With no alignment ``rmse_3d``/``mean_3d``/
  ``std_3d``/``max_3d`` are evo's APE (translation part) statistics.
- **Per axis** (east, north, up; the up axis is the vertical error): ``rms`` (population,
  bias included), ``mean`` (signed bias), ``std`` (population: ``rms^2 = mean^2 +
  std^2``), ``min``/``max`` (signed extremes: paper 003's "minimum/maximum values"),
  ``absmax`` (max |d|: paper 002's "MAX" of Tables 3-4).
- **Transform**: ``align_scale``, ``align_roll_deg``, ``align_pitch_deg``,
  ``align_yaw_deg`` (intrinsic z-y'-x'', yaw counter-clockwise from east), ``align_east``,
  ``align_north``, ``align_up`` (translation, m): ``T(p) = s R p + t``, fitted on these
  epochs. An alignment the epochs do not determine (too few, on one line) leaves every
  statistic and the transform empty, ``n`` still counted.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np
import pandas as pd

from coopproc.model import FloatArray
from coopproc.report.alignment import ALIGNMENTS, AlignmentError, Transform, fit_alignment
from coopproc.report.evaluation_extra import EXTRA_COLUMNS, coverage_map, evaluation_extras
from coopproc.report.track_kernels import error_norms
from coopproc.report.tracks import REFERENCE_METHOD, Track, matched_tracks

__all__ = [
    "AXES",
    "EVALUATION_COLUMNS",
    "EVALUATION_KEYS",
    "REFERENCE_METHOD",
    "aligned_tracks",
    "check_alignments",
    "error_stats",
    "evaluation",
    "evaluation_frame",
    "evaluation_row",
    "matched_tracks",
]

AXES: tuple[str, ...] = ("east", "north", "up")
EVALUATION_KEYS: tuple[str, ...] = ("platform", "method", "alignment")
_NORM_STATS = ("rmse", "mean", "median", "std", "min", "max")
_AXIS_STATS = ("rms", "mean", "std", "min", "max", "absmax")
_TRANSFORM = (
    "align_scale",
    "align_roll_deg",
    "align_pitch_deg",
    "align_yaw_deg",
    "align_east",
    "align_north",
    "align_up",
)
#: Columns of ``evaluation.csv``, in order.
EVALUATION_COLUMNS: tuple[str, ...] = (
    *EVALUATION_KEYS,
    "n",
    *(f"{s}_3d" for s in _NORM_STATS),
    *(f"{s}_h" for s in _NORM_STATS),
    *(f"{s}_{a}" for s in _AXIS_STATS for a in AXES),
    *_TRANSFORM,
    *EXTRA_COLUMNS,  # coverage, along / cross-track, intervals (report/evaluation_extra.py)
)


def check_alignments(names: Sequence[str]) -> tuple[str, ...]:
    """``names`` as a tuple (each once); ValueError naming the first unknown one."""
    for name in names:
        if name not in ALIGNMENTS:
            raise ValueError(f"unknown alignment {name!r}; expected one of {', '.join(ALIGNMENTS)}")
    return tuple(dict.fromkeys(names))


def _norm_stats(x: FloatArray, suffix: str) -> dict[str, float]:
    return {
        f"rmse_{suffix}": float(np.sqrt(np.mean(x * x))),
        f"mean_{suffix}": float(np.mean(x)),
        f"median_{suffix}": float(np.median(x)),
        f"std_{suffix}": float(np.std(x)),
        f"min_{suffix}": float(np.min(x)),
        f"max_{suffix}": float(np.max(x)),
    }


def error_stats(error: FloatArray) -> dict[str, float]:
    """The statistics of (n, 3) east/north/up errors (module doc); NaN for n = 0."""
    d = np.ascontiguousarray(error, dtype=np.float64).reshape(-1, 3)
    return _error_stats(d, np.zeros_like(d))


def _error_stats(moved: FloatArray, ref: FloatArray) -> dict[str, float]:
    """:func:`error_stats` of ``moved - ref`` without forming it (one compiled pass for the
    norms and the per-axis statistics: :func:`~coopproc.report.track_kernels.error_norms`)."""
    if not moved.shape[0]:
        names = [c for c in EVALUATION_COLUMNS[4:] if c not in (*_TRANSFORM, *EXTRA_COLUMNS)]
        return dict.fromkeys(names, float("nan"))
    e3, h, axis_stats = error_norms(moved, ref)
    out = _norm_stats(e3, "3d")
    out.update(_norm_stats(h, "h"))
    for row, stat in enumerate(_AXIS_STATS):
        for k, axis in enumerate(AXES):
            out[f"{stat}_{axis}"] = float(axis_stats[row, k])
    return out


def transform_columns(transform: Transform | None) -> dict[str, float]:
    """The ``align_*`` columns of a fitted transform (NaN for None)."""
    if transform is None:
        return dict.fromkeys(_TRANSFORM, float("nan"))
    roll, pitch, yaw = transform.euler_deg()
    t = transform.translation
    values = (transform.scale, roll, pitch, yaw, t[0], t[1], t[2])
    return {name: float(v) + 0.0 for name, v in zip(_TRANSFORM, values, strict=True)}


def aligned_tracks(
    positions: pd.DataFrame,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> Iterator[tuple[str, str, str, FloatArray, FloatArray, FloatArray, Transform | None]]:
    """``(platform, method, align, time, aligned est, ref, transform)``, rows in the order
    of ``evaluation.csv``: platform, then alignment (as given), then method. The transform
    is None (and ``aligned est`` all NaN) where the alignment is undetermined. One
    platform's tracks are held at a time (none with a single alignment)."""
    align = check_alignments(align)
    held: list[Track] = []
    for track in matched_tracks(positions, methods):
        if len(align) == 1:
            yield from _aligned(track, align[0])
            continue
        if held and held[0].platform != track.platform:
            yield from (a for kind in align for item in held for a in _aligned(item, kind))
            held = []
        held.append(track)
    yield from (a for kind in align for item in held for a in _aligned(item, kind))


def _aligned(
    track: Track, kind: str
) -> Iterator[tuple[str, str, str, FloatArray, FloatArray, FloatArray, Transform | None]]:
    platform, method, t, est, ref = track
    try:
        transform: Transform | None = fit_alignment(kind, est, ref)
    except AlignmentError:
        transform = None
    if transform is None:
        moved = np.full_like(est, np.nan)
    elif kind == "none":  # the identity's s R p + t, bit for bit (-0.0 becomes 0.0)
        moved = est + 0.0
    else:
        moved = transform.apply(est)
    yield platform, method, kind, t, moved, ref, transform


def evaluation_row(
    platform: str,
    method: str,
    kind: str,
    moved: FloatArray,
    ref: FloatArray,
    transform: Transform | None,
    time_s: FloatArray | None = None,
    covered: float = float("nan"),
) -> dict[str, object]:
    """One row of ``evaluation.csv`` from an item of :func:`aligned_tracks` (``time_s``
    its times: the along / cross-track errors and the intervals; ``covered`` its
    coverage, :func:`~coopproc.report.evaluation_extra.coverage_map`)."""
    row: dict[str, object] = {"platform": platform, "method": method, "alignment": kind}
    row["n"] = int(ref.shape[0])
    if transform is None:
        row.update(error_stats(np.empty((0, 3))))
    else:
        row.update(_error_stats(moved, ref))
    row.update(transform_columns(transform))
    t = np.arange(float(ref.shape[0])) if time_s is None else time_s
    usable = moved if transform is not None else np.empty((0, 3))
    row.update(
        evaluation_extras(t, usable, ref[: usable.shape[0]], covered, (platform, method, kind))
    )
    return row


def evaluation_frame(rows: list[dict[str, object]]) -> pd.DataFrame:
    """``evaluation.csv`` from its rows (:func:`evaluation_row`)."""
    out = pd.DataFrame(rows, columns=list(EVALUATION_COLUMNS))
    out["n"] = out["n"].astype(np.int64)
    return out


def evaluation(
    positions: pd.DataFrame,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """``evaluation.csv``: one row per platform, alignment and method (module doc).

    ``align``: the alignments (:data:`~coopproc.report.alignment.ALIGNMENTS`), each a block
    of rows; ``methods``: the run's position methods (default: derived from the table).
    With ``rpe.csv`` too, :func:`coopproc.report.rpe.evaluation_and_rpe` aligns once.
    """
    covered = coverage_map(positions)
    return evaluation_frame(
        [
            evaluation_row(
                platform,
                method,
                kind,
                moved,
                ref,
                transform,
                t,
                covered.get((platform, method), float("nan")),
            )
            for platform, method, kind, t, moved, ref, transform in aligned_tracks(
                positions, align, methods
            )
        ]
    )
