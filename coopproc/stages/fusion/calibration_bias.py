"""Post-fit residuals and the range bias of one platform (the self-calibration's step 3).

:mod:`coopproc.stages.fusion.calibration` takes each pair's ranging error from the post-fit
residuals ``L - ||X_a - X_b||`` of a fusion (:func:`postfit_residuals`). When one platform's
pairs are all worse than the others' (:func:`platform_range_factor`: the median sigma of its
pairs over the median of the others', above :data:`PLATFORM_RANGE_LIMIT`), its ranges may
all read long (or short) by a constant b_p: body shadowing, an antenna delay. The bias is
estimated (:func:`platform_bias`, an iteration of whole fusions) only when it matters
(:func:`biased_platform`): the median residual of the platform's ranges less that of the
other ranges,

    b^_p = median(r_i, i in ranges of p) - median(r_j, j not in ranges of p),

must be :data:`BIAS_EFFECT` (0.5) of the platform's ranging sigma or more. An effect size,
not a significance: it does not grow with the number of ranges. The RMS ratio alone does
grow with the session length where the fused solution degrades over time: on the simulated
``large`` scenario (10 platforms, no range bias in the data) the followers' gyro biases
(up to 2.7 deg/h) let the fused formation drift further from the ranges as the session
gets longer; the two platforms at the wedge's ends, whose pairs are the longest, reach
an RMS ratio of 1.05 / 1.36 / 1.58 at 1 / 4 / 8 h, while their b^_p stays at -0.002 /
-0.02 / -0.03 m against a ranging sigma of 0.15 m. On the real TIERS session, tb4's ranges
read 0.1-0.74 m long: b^_p = +0.122 m against 0.121 m, and the iteration finds +0.294 m.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from coopproc.estimation.range_model import slant_ranges
from coopproc.model import FloatArray, Session, pair_members, pair_name
from coopproc.stages.fusion.fuse import FusionOutput, FusionParams, fuse
from coopproc.stages.shared.data import anchor_positions

__all__ = [
    "PairCodes",
    "bias_words",
    "biased_platform",
    "code_groups",
    "corrected",
    "pair_codes",
    "platform_bias",
    "platform_rows",
    "postfit_residuals",
    "residuals_by_row",
]

#: A platform bias is kept only if it cuts the RMS of that platform's residuals to this.
BIAS_GAIN = 0.9
#: A platform whose pairs' median sigma is this many times the others' is weighted down.
PLATFORM_RANGE_LIMIT = 1.5
#: Platform range bias iteration: stop when it moves less than this (m) ...
BIAS_TOL_M = 0.01
#: ... or after this many fusions.
BIAS_ITERATIONS = 8
#: A platform range bias is estimated only when the median post-fit residual of the
#: platform's ranges, less that of the other ranges, is at least this fraction of its
#: ranging sigma (a bias that matters against the noise it would change).
BIAS_EFFECT = 0.5


def _positions(
    fused: FusionOutput, anchors: Mapping[str, FloatArray], pid: str, t: FloatArray
) -> FloatArray | None:
    """Positions (n, 3) of ``pid`` at ``t``: an anchor's fixed one, a moving platform's
    fused one; None for a platform with neither."""
    if pid in anchors:
        return np.tile(anchors[pid], (t.shape[0], 1))
    if pid in fused.smoothed:
        return fused.smoothed[pid].interpolate(t)
    return None


def residuals_by_row(session: Session, fused: FusionOutput, ranges: pd.DataFrame) -> FloatArray:
    """Each row of ``ranges`` minus the fused distance at its time (NaN where the range is
    not finite or a platform has no position).

    Each platform's trajectory is interpolated once, at the times of every row it is the
    ``from`` end of, then once at those it is the ``to`` end of (not once per pair: each
    call copies the trajectory's strided columns); a distance does not depend on the
    order of its ends, so the residuals are those of a pair-by-pair loop, bit for bit."""
    anchors = anchor_positions(session)
    value = ranges["range"].to_numpy(dtype=np.float64)
    t = ranges["time"].to_numpy(dtype=np.float64)
    resid = np.full(t.shape[0], np.nan)
    start = np.full((t.shape[0], 3), np.nan)  # the from end's position per row
    finite = np.isfinite(value)
    for end in ("from", "to"):
        code, uniques = pd.factorize(ranges[end])  # a missing id: -1, no position
        usable = np.flatnonzero(finite & (code >= 0))
        for k, sel in code_groups(code[usable], len(uniques)):
            rows = usable[sel]
            x = _positions(fused, anchors, str(uniques[k]), t[rows])
            if x is None:
                continue
            if end == "from":
                start[rows] = x
            else:
                resid[rows] = value[rows] - slant_ranges(start[rows] - x)
    return resid


def postfit_residuals(session: Session, fused: FusionOutput, ranges: pd.DataFrame) -> pd.DataFrame:
    """Columns time, pair (categorical), residual: each range with a finite value minus
    the fused distance at its time."""
    pairs = pair_codes(ranges["from"], ranges["to"])
    resid = residuals_by_row(session, fused, ranges)
    keep = np.isfinite(ranges["range"].to_numpy(dtype=np.float64))
    return pd.DataFrame(
        {
            "time": ranges["time"].to_numpy(dtype=np.float64)[keep],
            "pair": pd.Categorical.from_codes(
                pairs.code[keep], dtype=pd.CategoricalDtype(list(pairs.names))
            ),
            "residual": resid[keep],
        }
    )


@dataclass(frozen=True)
class PairCodes:
    """Each row's unordered pair (:func:`~coopproc.model.pair_name`) as a code into
    ``names``, the distinct pair names sorted."""

    code: NDArray[np.signedinteger]  # int16 below 32,768 pairs: 2 bytes a row
    names: tuple[str, ...]


def pair_codes(first: pd.Series, second: pd.Series) -> PairCodes:
    """:class:`PairCodes` of two id columns: one factorization per column, a name per
    distinct (first, second) combination, no string per row (a missing id is named
    ``str`` of it, as :func:`~coopproc.stages.shared.data.pair_names` does)."""
    code_a, uniq_a = pd.factorize(first, use_na_sentinel=False)
    code_b, uniq_b = pd.factorize(second, use_na_sentinel=False)
    width = max(len(uniq_b), 1)
    key = code_a.astype(np.int64) * width + code_b
    present = np.zeros(max(len(uniq_a), 1) * width, dtype=bool)
    present[key] = True
    combos = np.flatnonzero(present)
    combo_names = [
        pair_name(str(uniq_a[int(k) // width]), str(uniq_b[int(k) % width])) for k in combos
    ]
    names, rank = np.unique(np.array(combo_names, dtype=object), return_inverse=True)
    lut = np.zeros(present.shape[0], dtype=_code_dtype(len(names)))
    lut[combos] = rank.reshape(-1)
    return PairCodes(lut[key], tuple(str(n) for n in names))


def _code_dtype(n: int) -> type[np.signedinteger]:
    """The smallest of int16 / int32 / int64 holding codes 0..n-1."""
    return np.int16 if n < 2**15 else np.int32 if n < 2**31 else np.int64


def code_groups(code: np.ndarray, n: int) -> list[tuple[int, np.ndarray]]:
    """(code, row indices ascending) of each code 0..n-1 that occurs: one stable sort."""
    small = code.astype(_code_dtype(n), copy=False)  # int16: numpy's radix sort
    order = np.argsort(small, kind="stable")
    bounds = np.concatenate(([0], np.cumsum(np.bincount(code, minlength=n))))
    return [(i, order[bounds[i] : bounds[i + 1]]) for i in range(n) if bounds[i + 1] > bounds[i]]


def platform_rows(ranges: pd.DataFrame, platform: str) -> np.ndarray:
    """Boolean mask of the rows of ``ranges`` that ``platform`` takes part in (as from or
    to): a factorization per column, no string comparison per row."""
    own = np.zeros(len(ranges), dtype=bool)
    for column in ("from", "to"):
        code, uniques = pd.factorize(ranges[column])
        hit = [i for i, u in enumerate(uniques) if u == platform]
        if hit:
            own |= code == hit[0]
    return own


def platform_range_factor(pair_sigma: Mapping[str, float]) -> dict[str, float]:
    """The platform whose pairs are all worse than the rest (a body-blocked antenna), if
    any: the median sigma of its pairs over the median of the other pairs, where above
    :data:`PLATFORM_RANGE_LIMIT` and the platform has 3+ pairs and the others 3+ too. Only
    the worst one: biases of several platforms at once trade off against each other."""
    members: dict[str, list[float]] = {}
    ends = {pair: pair_members(pair) for pair in pair_sigma}
    for pair, sigma in pair_sigma.items():
        for platform in ends[pair]:
            members.setdefault(platform, []).append(sigma)
    factors: dict[str, float] = {}
    for platform, own in members.items():
        others = [s for pair, s in pair_sigma.items() if platform not in ends[pair]]
        if len(own) < 3 or len(others) < 3:
            continue
        factors[platform] = float(np.median(own)) / float(np.median(others))
    if not factors:
        return {}
    worst = max(sorted(factors), key=lambda p: factors[p])
    return {worst: factors[worst]} if factors[worst] > PLATFORM_RANGE_LIMIT else {}


def relative_bias(resid: FloatArray, ranges: pd.DataFrame, platform: str) -> float:
    """The median post-fit residual of the ranges ``platform`` takes part in, less the
    median of the other ranges' (a network-wide offset is no platform's bias); NaN when
    either set is empty."""
    own = platform_rows(ranges, platform)
    finite = np.isfinite(resid)
    mine, others = resid[own & finite], resid[~own & finite]
    if not mine.shape[0] or not others.shape[0]:
        return float("nan")
    return float(np.median(mine)) - float(np.median(others))


def platform_bias(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    platforms: Mapping[str, float],
    rows: np.ndarray | None = None,
) -> tuple[pd.DataFrame, dict[str, float]]:
    """A constant range bias of each listed platform: every range it takes part in reads
    long (or short) by b_p. The fit absorbs part of a bias into the positions, so b_p is
    found by iteration: fuse, add the median post-fit residual of the platform's ranges to
    b_p, correct the ranges, fuse again, until b_p moves less than :data:`BIAS_TOL_M` (at
    most :data:`BIAS_ITERATIONS` times). Identifiable because the platform is ranged from
    three or more directions: a position shift lengthens some ranges and shortens others.

    ``rows``: iterate on these rows only (a thinned subset of a long session,
    :mod:`~coopproc.stages.fusion.calibration_subset`), then one step on every range (a
    thinned fusion absorbs a little more of a bias). Returns every row, corrected."""
    if rows is None:
        return _iterate(session, ranges, params, platforms)
    _, bias = _iterate(session, ranges.iloc[rows], params, platforms)
    if not bias:
        return ranges, {}
    current = corrected(ranges, bias)
    fused = fuse(session, current, params, output="ranges", smoothed_sigma=False, dr_faults="off")
    resid = residuals_by_row(session, fused, current)
    for platform in bias:
        r = resid[platform_rows(ranges, platform)]
        r = r[np.isfinite(r)]
        bias[platform] += float(np.median(r)) if r.shape[0] else 0.0
    return corrected(ranges, bias), bias


def _iterate(
    session: Session,
    ranges: pd.DataFrame,
    params: FusionParams,
    platforms: Mapping[str, float],
) -> tuple[pd.DataFrame, dict[str, float]]:
    """:func:`platform_bias` on ``ranges``; the bias is kept only if it cuts the RMS of
    the platform's residuals to :data:`BIAS_GAIN` of what it was."""
    base = ranges["range"].to_numpy(dtype=np.float64)
    involved = {p: platform_rows(ranges, p) for p in platforms}
    bias = dict.fromkeys(platforms, 0.0)
    current = ranges
    rms_first = float("nan")
    for _ in range(BIAS_ITERATIONS):
        fused = fuse(
            session, current, params, output="ranges", smoothed_sigma=False, dr_faults="off"
        )
        resid = residuals_by_row(session, fused, current)
        if np.isnan(rms_first):
            rms_first = _rms(resid, involved)
        step = {}
        for platform, sel in involved.items():
            r = resid[sel]
            r = r[np.isfinite(r)]
            step[platform] = float(np.median(r)) if r.shape[0] else 0.0
            bias[platform] += step[platform]
        corrected = base.copy()
        for platform, sel in involved.items():
            corrected[sel] -= bias[platform]
        current = ranges.assign(range=corrected)
        if max(abs(v) for v in step.values()) < BIAS_TOL_M:
            break
    fused = fuse(session, current, params, output="ranges", smoothed_sigma=False, dr_faults="off")
    rms_last = _rms(residuals_by_row(session, fused, current), involved)
    if not rms_last < BIAS_GAIN * rms_first:
        return ranges, {}  # the bias does not explain the disagreement: leave the ranges
    return current, bias


def _rms(resid: FloatArray, involved: Mapping[str, np.ndarray]) -> float:
    """RMS of the finite residuals of the ranges of the listed platforms."""
    sel = np.zeros(resid.shape[0], dtype=bool)
    for mask in involved.values():
        sel |= mask
    r = resid[sel]
    r = r[np.isfinite(r)]
    return float(np.sqrt(np.mean(r * r))) if r.shape[0] else float("nan")


def biased_platform(
    pair_sigma: Mapping[str, float],
    resid: FloatArray,
    ranges: pd.DataFrame,
    given: FloatArray,
) -> dict[str, float]:
    """The platform whose pairs are all worse than the rest (:func:`platform_range_factor`)
    if its relative median residual (:func:`relative_bias`) is :data:`BIAS_EFFECT` of its
    ranges' median given sigma or more; else none. ``resid``, ``given``: per row of
    ``ranges``."""
    out = {}
    for platform, factor in platform_range_factor(pair_sigma).items():
        own = platform_rows(ranges, platform)
        sigma = float(np.median(given[own])) if own.any() else float("nan")
        if abs(relative_bias(resid, ranges, platform)) >= BIAS_EFFECT * sigma:
            out[platform] = factor
    return out


def corrected(ranges: pd.DataFrame, bias: Mapping[str, float]) -> pd.DataFrame:
    """``ranges`` with each listed platform's ranges corrected by minus its bias."""
    corrected = ranges["range"].to_numpy(dtype=np.float64).copy()
    for platform, value in bias.items():
        corrected[platform_rows(ranges, platform)] -= value
    return ranges.assign(range=corrected)


def bias_words(bias_m: float) -> str:
    """A signed range bias in words: ``+0.131`` reads "0.131 m long", ``-0.131`` "0.131 m
    short" (a positive bias: the ranges exceed the geometry's distances; issue 32)."""
    return f"{abs(bias_m):.3f} m {'long' if bias_m > 0 else 'short'}"
