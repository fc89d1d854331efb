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

from coopproc.model import FloatArray, gap_limit_s
from coopproc.report.alignment import ALIGNMENTS, AlignmentError, Transform, fit_alignment
from coopproc.report.methods import method_order, position_methods_of

__all__ = [
    "AXES",
    "EVALUATION_COLUMNS",
    "EVALUATION_KEYS",
    "REFERENCE_METHOD",
    "aligned_tracks",
    "check_alignments",
    "error_stats",
    "evaluation",
    "matched_tracks",
]

REFERENCE_METHOD = "reference"
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
)


def check_alignments(names: Sequence[str]) -> tuple[str, ...]:
    """``names`` as a tuple (each once); ValueError naming the first unknown one."""
    for name in names:
        if name not in ALIGNMENTS:
            raise ValueError(f"unknown alignment {name!r}; expected one of {', '.join(ALIGNMENTS)}")
    return tuple(dict.fromkeys(names))


def _column(frame: pd.DataFrame, name: str) -> FloatArray:
    return frame[name].to_numpy(dtype=np.float64, na_value=np.nan)


def _reference_at(ref: pd.DataFrame, t: FloatArray) -> FloatArray:
    """The reference rows (sorted by time) at times ``t``; NaN outside them or in a gap."""
    t_ref = _column(ref, "time")
    out = np.full((t.size, 3), np.nan)
    if not t_ref.size:
        return out
    for k, axis in enumerate(AXES):
        out[:, k] = np.interp(t, t_ref, _column(ref, axis), left=np.nan, right=np.nan)
    right = np.searchsorted(t_ref, t)
    exact = t_ref[np.minimum(right, t_ref.size - 1)] == t
    if t_ref.size >= 2:
        steps = np.diff(t_ref)
        idx = np.clip(right, 1, t_ref.size - 1)
        out[(steps[idx - 1] > gap_limit_s(t_ref)) & ~exact] = np.nan
    return out


def matched_tracks(
    positions: pd.DataFrame, methods: Sequence[str] | None = None
) -> Iterator[tuple[str, str, FloatArray, FloatArray, FloatArray]]:
    """``(platform, method, time, est, ref)`` per platform and method with a reference.

    ``est`` and ``ref`` are (n, 3) ENU positions at the evaluation epochs (module doc), in
    time order. Platforms sorted; methods ``nav``, then ``methods`` (by default those of
    the table: :func:`~coopproc.report.methods.position_methods_of`), then any other
    alphabetically; ``reference`` is never a method. A platform without reference rows
    yields nothing.
    """
    order = ("nav", *(position_methods_of(positions) if methods is None else methods))
    for platform, group in positions.groupby("platform", sort=True):
        ref = group[group["method"] == REFERENCE_METHOD].sort_values("time", kind="stable")
        present = sorted(str(m) for m in group["method"].unique() if m != REFERENCE_METHOD)
        for method in method_order(present, order):
            own = group[group["method"] == method].sort_values("time", kind="stable")
            t = _column(own, "time")
            est = np.column_stack([_column(own, a) for a in AXES])
            truth = _reference_at(ref, t)
            keep = (
                np.isfinite(_column(own, "error_h"))
                & np.all(np.isfinite(est), axis=1)
                & np.all(np.isfinite(truth), axis=1)
            )
            yield str(platform), method, t[keep], est[keep], truth[keep]


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
    d = np.asarray(error, dtype=np.float64).reshape(-1, 3)
    if not d.shape[0]:
        names = [c for c in EVALUATION_COLUMNS[4:] if c not in _TRANSFORM]
        return dict.fromkeys(names, float("nan"))
    out = _norm_stats(np.sqrt(np.sum(d * d, axis=1)), "3d")
    out.update(_norm_stats(np.hypot(d[:, 0], d[:, 1]), "h"))
    axis_stats = {
        "rms": np.sqrt(np.mean(d * d, axis=0)),
        "mean": np.mean(d, axis=0),
        "std": np.std(d, axis=0),
        "min": np.min(d, axis=0),
        "max": np.max(d, axis=0),
        "absmax": np.max(np.abs(d), axis=0),
    }
    for stat, values in axis_stats.items():
        for k, axis in enumerate(AXES):
            out[f"{stat}_{axis}"] = float(values[k])
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
    is None (and ``aligned est`` all NaN) where the alignment is undetermined."""
    align = check_alignments(align)
    tracks: dict[str, list[tuple[str, FloatArray, FloatArray, FloatArray]]] = {}
    for platform, method, t, est, ref in matched_tracks(positions, methods):
        tracks.setdefault(platform, []).append((method, t, est, ref))
    for platform, items in tracks.items():
        for kind in align:
            for method, t, est, ref in items:
                try:
                    transform: Transform | None = fit_alignment(kind, est, ref)
                except AlignmentError:
                    transform = None
                moved = np.full_like(est, np.nan) if transform is None else transform.apply(est)
                yield platform, method, kind, t, moved, ref, transform


def evaluation(
    positions: pd.DataFrame,
    align: Sequence[str] = ("none",),
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """``evaluation.csv``: one row per platform, alignment and method (module doc).

    ``align``: the alignments (:data:`~coopproc.report.alignment.ALIGNMENTS`), each a block
    of rows; ``methods``: the run's position methods (default: derived from the table).
    """
    rows: list[dict[str, object]] = []
    for platform, method, kind, _t, moved, ref, transform in aligned_tracks(
        positions, align, methods
    ):
        row: dict[str, object] = {"platform": platform, "method": method, "alignment": kind}
        row["n"] = int(ref.shape[0])
        ok = transform is not None
        row.update(error_stats(moved - ref if ok else np.empty((0, 3))))
        row.update(transform_columns(transform))
        rows.append(row)
    out = pd.DataFrame(rows, columns=list(EVALUATION_COLUMNS))
    out["n"] = out["n"].astype(np.int64)
    return out
