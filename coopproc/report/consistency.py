"""Filter consistency: does a filter's claimed uncertainty match its errors?

- **NIS** (normalized innovation squared) of the cooperative fusion's range innovations,
  ``range_weights.csv``: ``NIS_i = standardized_i^2``, the innovation over its predicted
  sigma (and over the MAD unit-weight sigma, floored at 1: docs/outputs.md; with the MAD
  above 1 this is a lower bound of the NIS). A consistent filter's NIS is chi-square with
  1 degree of freedom: mean 1, above ``chi2_0.95(1) = 3.84`` at 5 % of the ranges.
- **NEES** (normalized estimation error squared) of the INS methods' velocity and
  attitude, ``states.csv`` against its ``reference`` rows (interpolated to the method's
  epochs, attitude differences wrapped to +-180 deg): ``sum_k (err_k / sigma_k)^2`` over
  the 3 axes (the file has the marginal sigmas only: correlations between axes are not
  counted), chi-square with 3 degrees of freedom if consistent: mean 3, above
  ``chi2_0.95(3) = 7.81`` at 5 %. positions.csv carries no position sigma, so positions
  have no NEES.

A method is **overconfident** when more than :data:`OVERCONFIDENT_SHARE` of its epochs
exceed the 95 % bound (twice the share a consistent filter has): ``coopproc run`` says
so in one line. Per platform and method the figures are appended to ``evaluation.csv``
(:data:`CONSISTENCY_COLUMNS`; a range counts for both its platforms) and drawn in
``consistency.png`` (:mod:`coopproc.report.consistency_figure`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np
import pandas as pd

from coopproc.distributions import chi2_ppf
from coopproc.model import FloatArray, pair_members
from coopproc.report.table_specs import method_label

__all__ = [
    "CONSISTENCY_COLUMNS",
    "OVERCONFIDENT_SHARE",
    "bound",
    "consistency_lines",
    "nees_series",
    "nis_series",
    "with_consistency",
]

#: Share of epochs above the 95 % bound beyond which a method is called overconfident.
OVERCONFIDENT_SHARE = 0.10
#: Columns appended to evaluation.csv.
CONSISTENCY_COLUMNS: tuple[str, ...] = (
    "nis_n",
    "nis_mean",
    "nis_above",
    "nees_vel_n",
    "nees_vel_mean",
    "nees_vel_above",
    "nees_att_n",
    "nees_att_mean",
    "nees_att_above",
)
_VEL = ("vel_east", "vel_north", "vel_up")
_ATT = ("roll", "pitch", "yaw")


def bound(dof: int, level: float = 0.95) -> float:
    """The chi-square quantile a consistent filter's NIS / NEES stays below at ``level``."""
    return float(chi2_ppf(level, dof))


def nis_series(
    range_weights: pd.DataFrame | None,
) -> Iterator[tuple[str, str, FloatArray, FloatArray]]:
    """``(pair, method, time, NIS)`` of every pair and fusion method (time order)."""
    needed = {"time", "pair", "method", "standardized"}
    if range_weights is None or not len(range_weights) or not needed <= set(range_weights):
        return
    for (pair, method), part in range_weights.groupby(["pair", "method"], sort=True):
        part = part.sort_values("time", kind="stable")
        s = part["standardized"].to_numpy(dtype=np.float64, na_value=np.nan)
        yield str(pair), str(method), part["time"].to_numpy(dtype=np.float64), s * s


def _wrap_deg(x: FloatArray) -> FloatArray:
    return (x + 180.0) % 360.0 - 180.0


def nees_series(
    states: pd.DataFrame | None,
) -> Iterator[tuple[str, str, str, FloatArray, FloatArray]]:
    """``(platform, method, "vel" | "att", time, NEES)`` of every INS method with sigmas
    and a reference (module doc)."""
    if states is None or not len(states) or "sigma_vel_east" not in states.columns:
        return
    for platform, rows in states.groupby("platform", sort=True):
        ref = rows[rows["method"] == "reference"].sort_values("time", kind="stable")
        if len(ref) < 2:
            continue
        t_ref = ref["time"].to_numpy(dtype=np.float64)
        for method, part in rows[rows["method"] != "reference"].groupby("method", sort=True):
            part = part.sort_values("time", kind="stable")
            t = part["time"].to_numpy(dtype=np.float64)
            for kind, axes in (("vel", _VEL), ("att", _ATT)):
                total = np.zeros(t.size)
                for axis in axes:
                    truth = ref[axis].to_numpy(dtype=np.float64, na_value=np.nan)
                    at = np.interp(t, t_ref, truth, left=np.nan, right=np.nan)
                    err = part[axis].to_numpy(dtype=np.float64, na_value=np.nan) - at
                    if kind == "att":
                        err = _wrap_deg(err)
                    sigma = part[f"sigma_{axis}"].to_numpy(dtype=np.float64, na_value=np.nan)
                    with np.errstate(divide="ignore", invalid="ignore"):
                        total += (err / sigma) ** 2
                yield str(platform), str(method), kind, t, total


def _summary(values: list[FloatArray], dof: int) -> tuple[int, float, float]:
    x = np.concatenate(values) if values else np.empty(0)
    x = x[np.isfinite(x)]
    if not x.size:
        return 0, float("nan"), float("nan")
    return int(x.size), float(np.mean(x)), float(np.mean(x > bound(dof)))


def _by_platform(
    range_weights: pd.DataFrame | None, states: pd.DataFrame | None
) -> dict[tuple[str, str], dict[str, float]]:
    nis: dict[tuple[str, str], list[FloatArray]] = {}
    for pair, method, _t, values in nis_series(range_weights):
        for platform in pair_members(pair):
            nis.setdefault((platform, method), []).append(values)
    nees: dict[tuple[str, str, str], list[FloatArray]] = {}
    for platform, method, kind, _t, values in nees_series(states):
        nees.setdefault((platform, method, kind), []).append(values)
    out: dict[tuple[str, str], dict[str, float]] = {}
    for key, series in nis.items():
        n, mean, above = _summary(series, 1)
        out.setdefault(key, {}).update(nis_n=n, nis_mean=mean, nis_above=above)
    for (platform, method, kind), found in nees.items():
        n, mean, above = _summary(found, 3)
        row = out.setdefault((platform, method), {})
        row.update({f"nees_{kind}_n": n, f"nees_{kind}_mean": mean, f"nees_{kind}_above": above})
    return out


def with_consistency(
    evaluation: pd.DataFrame, range_weights: pd.DataFrame | None, states: pd.DataFrame | None
) -> pd.DataFrame:
    """``evaluation`` with :data:`CONSISTENCY_COLUMNS` appended (per platform and method;
    empty where the method has no innovations or sigmas; counts 0)."""
    found = _by_platform(range_weights, states)
    out = evaluation.copy()
    for column in CONSISTENCY_COLUMNS:
        values = [
            found.get((str(p), str(m)), {}).get(column, 0 if column.endswith("_n") else np.nan)
            for p, m in zip(out["platform"], out["method"], strict=True)
        ]
        out[column] = pd.Series(values, index=out.index, dtype=np.float64)
        if column.endswith("_n"):
            out[column] = out[column].astype(np.int64)
    return out


def consistency_lines(
    range_weights: pd.DataFrame | None,
    states: pd.DataFrame | None,
    labels: Mapping[str, str] | None = None,
) -> list[str]:
    """One line per overconfident method: NIS over all its ranges, NEES over all its
    platforms (module doc)."""

    def name(method: str) -> str:
        return (labels or {}).get(method, method_label(method))

    nis: dict[str, list[FloatArray]] = {}
    for _pair, method, _t, values in nis_series(range_weights):
        nis.setdefault(method, []).append(values)
    lines = []
    for method, series in nis.items():
        n, mean, above = _summary(series, 1)
        if n and above > OVERCONFIDENT_SHARE:
            lines.append(
                f"warning: the {name(method)} fusion is overconfident: {100 * above:.0f} % of "
                f"its {n} range innovations exceed the 95 % chi-square bound (NIS {bound(1):.2f}; "
                f"5 % if consistent), mean NIS {mean:.2f} (1 if consistent): its range or "
                "drift sigmas are too small (consistency.png)"
            )
    nees: dict[tuple[str, str], list[FloatArray]] = {}
    for _platform, method, kind, _t, values in nees_series(states):
        nees.setdefault((method, kind), []).append(values)
    words = {"vel": "velocity", "att": "attitude"}
    for (method, kind), found in nees.items():
        n, mean, above = _summary(found, 3)
        if n and above > OVERCONFIDENT_SHARE:
            lines.append(
                f"warning: {name(method)}'s {words[kind]} is overconfident: {100 * above:.0f} % "
                f"of {n} epochs exceed the 95 % chi-square bound (NEES {bound(3):.2f}), mean "
                f"NEES {mean:.2f} (3 if consistent; consistency.png)"
            )
    return lines
