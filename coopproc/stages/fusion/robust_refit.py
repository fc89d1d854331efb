"""The robust factors from the smoothed solution: one iteration of a robust smoother.

Paper 002's IGG-III factor (eq. (18)-(20)) is decided in the forward filter, on the
innovation at the prior: a range that arrives while the filter is uncertain (after a
turn, a gap, or inside a long NLOS run whose first ranges were taken in) is judged against
a prediction that it cannot contradict, and the smoother then takes the forward pass's
factors as they are. A batch factor graph with a robust (Huber) range loss re-weights
every range against the whole trajectory instead (iteratively re-weighted least squares).
:func:`smoothed_gammas` does that once for the EKF: each range's residual against the
smoothed positions of its two ends at its epoch, standardized by its sigma and the MAD
unit-weight sigma of all the ranges' residuals (eq. (20) over the whole session, floored
at ``mad_floor``), gives its IGG-III factor (eq. (18)); the filter and smoother then run
again with those factors fixed (``ekf_forward``'s ``gamma_in``). Observations other than
ranges (leaders' fixes), and ranges whose end has no recorded smoothed state at the
epoch, keep the forward pass's factor.

A platform whose dead reckoning slips or jumps (a wheel slip, a heading step) leaves the
filter's prediction of it off, and IGG-III then rejects every range it takes until the
drift covariance has grown enough to take them in again: the filter is locked out and
follows the faulty dead reckoning (simulated ``dr-faults`` seed 0: A off by 1.2 m for 50 s
after a slip, 84 ranges rejected, 18 of them really off). NLOS is a pair's own error, a
wrong position shows in all the platform's pairs: :func:`_platform_shifts` takes each
moving platform's ranges over :data:`SHIFT_WINDOW_S` and, where ranges with two or more of
its partners are rejected and it has ranges with three or more, fits one shift of its
position to all their residuals (weighted least squares, the residuals' standardizing
sigmas). If that shift leaves every range within k0 the platform, not the ranges, is off:
its rejected ranges get factor 1, and their residual and standardized value in
range_weights.csv are those with the shift. With two partners a shift fits any two
residuals, so the rule needs three; leaders (their own fixes place them) are left out.
``dr-faults`` seed 0: 47 rejected (27 really off), A's fused mean error 0.210 -> 0.147 m
(docs/methods-fusion.md).

``[fusion] robust_smoother_iterations`` (1 by default; 0: the forward factors only, as
paper 002 and 003 write it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.estimation.range_model import slant_ranges
from coopproc.estimation.robust import MAD_SCALE, igg3_factor
from coopproc.model import FloatArray
from coopproc.stages.fusion.ekf import OBS_ANCHOR, OBS_POSITION, OBS_RANGE

__all__ = ["smoothed_gammas"]


def _slot_of(
    key: NDArray[np.int64], rec_key: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    at = np.searchsorted(rec_key, key)
    at = np.minimum(at, max(rec_key.shape[0] - 1, 0))
    found = rec_key[at] == key if rec_key.shape[0] else np.zeros(key.shape[0], dtype=bool)
    return at, found


def smoothed_gammas(
    obs: dict[str, np.ndarray],
    rec_ptr: NDArray[np.int64],
    rec_plat: NDArray[np.int64],
    xs: FloatArray,
    n_plat: int,
    dim: int,
    gamma_forward: FloatArray,
    k0: float,
    k1: float,
    mad_floor: float,
    epoch_time: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Every observation's robust factor from the smoothed states ``xs`` (R, dim) at the
    recorded slots (module doc); ``gamma_forward`` where the smoothed one cannot be had.

    Also each observation's residual against the smoothed solution (m) and the
    standardized value its factor was taken from (residual / sigma / the MAD sigma), NaN
    where the forward factor stays: the decisions ``range_weights.csv`` shows."""
    ptr = obs["ptr"]
    n_ep = ptr.shape[0] - 1
    epoch = np.repeat(np.arange(n_ep, dtype=np.int64), np.diff(ptr))
    kind = obs["kind"].astype(np.int64)
    a = obs["a"].astype(np.int64)
    b = obs["b"].astype(np.int64)
    rec_epoch = np.repeat(np.arange(n_ep, dtype=np.int64), np.diff(rec_ptr))
    rec_key = rec_epoch * n_plat + rec_plat
    ranged = (kind == OBS_RANGE) | (kind == OBS_ANCHOR)
    at_a, found = _slot_of(epoch * n_plat + np.maximum(a, 0), rec_key)
    at_b, found_b = _slot_of(epoch * n_plat + np.maximum(b, 0), rec_key)
    found &= ranged & ((kind != OBS_RANGE) | found_b)
    offset = obs["anchor_table"][obs["anchor"].astype(np.int64), :dim]
    xa = xs[at_a]
    diff = np.where((kind == OBS_RANGE)[:, None], xa - xs[at_b] - offset, xa - offset)
    rho = slant_ranges(diff, obs["dz2"])
    resid_m = obs["z"] - rho
    resid = resid_m / np.sqrt(obs["var"])
    gamma = gamma_forward.copy()
    use = found & np.isfinite(resid)
    standardized = np.full(resid.shape[0], np.nan)
    if np.count_nonzero(use) == 0:
        return gamma, standardized, standardized.copy()
    sigma = max(MAD_SCALE * float(np.median(np.abs(resid[use]))), mad_floor)
    standardized[use] = resid[use] / sigma
    gamma[use] = igg3_factor(standardized[use], k0, k1)
    if epoch_time is not None:
        unit = diff / rho[:, None]
        residuals = _Residuals(
            epoch_time[epoch], a, b, obs["anchor"].astype(np.int64), kind, use, unit, resid_m,
            np.sqrt(obs["var"]) * sigma,
        )  # fmt: skip
        readmit, post = _platform_shifts(residuals, gamma, k0)
        gamma[readmit] = 1.0
        # their decision is taken from the residual with the end shifted
        resid_m[readmit] = post
        standardized[readmit] = post / (np.sqrt(obs["var"][readmit]) * sigma)
    resid_m[~use] = np.nan
    return gamma, resid_m, standardized


#: the span over which one platform's ranges are judged together (s)
SHIFT_WINDOW_S = 5.0


@dataclass(frozen=True)
class _Residuals:
    """Every observation's residual against the smoothed solution, with what the
    platform rule needs: time (s), ends, anchor code, kind, whether it was judged, the
    unit vector from ``b`` (or the anchor) to ``a``, the residual (m) and its
    standardizing sigma (m: the observation's sigma times the MAD unit sigma)."""

    time_s: FloatArray
    a: NDArray[np.int64]
    b: NDArray[np.int64]
    anchor: NDArray[np.int64]
    kind: NDArray[np.int64]
    use: NDArray[np.bool_]
    unit: FloatArray
    resid: FloatArray
    scale: FloatArray


def _platform_shifts(
    r: _Residuals, gamma: FloatArray, k0: float
) -> tuple[NDArray[np.int64], FloatArray]:
    """The rejected ranges that a shift of one of their ends explains (module doc), and
    their residuals (m) with that shift."""
    rejected = r.use & (gamma < 1.0)
    out: list[np.ndarray] = []
    post_m: list[np.ndarray] = []
    none = (np.zeros(0, dtype=np.int64), np.zeros(0))
    if np.count_nonzero(rejected) < 2:
        return none
    rows = np.flatnonzero(r.use)
    bins = np.floor(r.time_s / SHIFT_WINDOW_S).astype(np.int64)
    bins -= bins.min()
    fixed = np.unique(r.a[r.kind == OBS_POSITION])  # leaders: their own fixes place them
    # each range once per moving end: (platform, partner code, sign of d rho / d x)
    ends = [
        (r.a[rows], np.where(r.kind[rows] == OBS_RANGE, r.b[rows], -1 - r.anchor[rows]), 1.0, rows),
        (r.b[rows[r.kind[rows] == OBS_RANGE]], r.a[rows[r.kind[rows] == OBS_RANGE]], -1.0,
         rows[r.kind[rows] == OBS_RANGE]),
    ]  # fmt: skip
    for plat, partner, sign, at in ends:
        key = plat * (int(bins.max()) + 1) + bins[at]
        cand = np.unique(key[rejected[at] & ~np.isin(plat, fixed)])
        # only the candidate spans' rows, grouped by span (a day has millions of ranges
        # and a few thousand rejected)
        keep = np.flatnonzero(np.isin(key, cand))
        order = keep[np.argsort(key[keep], kind="stable")]
        starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
        for group in np.split(order, starts[1:]) if order.size else []:
            sel, part = at[group], partner[group]  # a platform's span with a rejected range
            if np.unique(part).shape[0] < 3 or np.unique(part[rejected[sel]]).shape[0] < 2:
                continue  # a shift fits two partners' residuals whatever they are
            jac = sign * r.unit[sel]  # d rho / d (this end's position)
            w = 1.0 / r.scale[sel]
            delta = np.linalg.lstsq(jac * w[:, None], r.resid[sel] * w, rcond=None)[0]
            post = r.resid[sel] - jac @ delta
            if np.all(np.abs(post * w) < k0):
                out.append(sel[rejected[sel]])
                post_m.append(post[rejected[sel]])
    if not out:
        return none
    rows_out, first = np.unique(np.concatenate(out), return_index=True)
    return rows_out, np.concatenate(post_m)[first]
