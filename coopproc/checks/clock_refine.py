"""Step 3 of the clock-offset estimate (:mod:`coopproc.checks.clock_fit`, eq. (1)):
Gauss-Newton for every platform's offset at once, biases per pair and block profiled out,
Huber weights, the 1-sigma from the residuals and the slope inflated by the
effective-sample-size factor of correlated residuals (:func:`ess_factor`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from coopproc.checks.clock_fit import PairData, velocity
from coopproc.estimation.range_model import slant_ranges_units
from coopproc.model import FloatArray, Trajectory

__all__ = ["BLOCKS_S", "HUBER_K", "Fit", "Motion", "demean", "ess_factor", "refine"]

#: Bias blocks of the refinement, s, the one giving the smallest 1-sigma is kept: a
#: dead reckoning's error changes by centimetres within a minute, and what the blocks do
#: not take out is a correlated residual that the offset absorbs. Measured (2 cm ranging
#: noise, 300 s, no offset): anchors' tag 5 s -2.7 +- 5.5 ms, 60 s -9.8 +- 10.5 ms, one bias
#: +4.0 +- 14.5 ms; land-vehicle 5 s 1.2 +- 1.6 ms, 60 s -6.2 +- 9.2 ms; paper-experiment's
#: followers 5 s 12 and -26 +- 17 ms, 60 s -7 and 21 +- 55 ms: short blocks win where the
#: navigation drifts, long ones where it is good and the distances change slowly.
BLOCKS_S = (5.0, 20.0, math.inf)
#: The integrated autocorrelation of :func:`_ess_factor` ends where rho falls below this.
ESS_FLOOR = 0.05
ESS_MAX_LAG = 500
#: Largest Gauss-Newton step, s: the coarse steps place the offset within a second.
MAX_STEP_S = 0.5
#: Huber's constant (in robust sigmas).
HUBER_K = 1.5


class Motion:
    """A trajectory's positions and velocities (differenced over +-:data:`VELOCITY_HALF_S`
    at its epochs, once) interpolated at any time: what eq. (1) and its Jacobian read."""

    def __init__(self, traj: Trajectory) -> None:
        self.traj = traj
        self._vel = velocity(traj, traj.time_s)

    def at(self, time_s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(positions, velocities) at ``time_s``; positions NaN outside the span."""
        t = self.traj.time_s
        vel = np.column_stack([np.interp(time_s, t, self._vel[:, i]) for i in range(3)])
        return self.traj.interpolate(time_s), vel


@dataclass(frozen=True)
class Fit:
    """The refinement of eq. (1): offsets and 1-sigmas of the estimated platforms."""

    offset_s: Mapping[str, float]
    sigma_s: Mapping[str, float]
    #: RMS of each platform's line-of-sight speed (the slope of eq. (1)), m/s
    slope_mps: Mapping[str, float]
    #: ranges used per platform
    count: Mapping[str, int]
    #: robust residual RMS, m, and the effective-sample-size factor
    residual_m: float
    ess_factor: float
    iterations: int
    block_s: float


def demean(block: NDArray[np.int64], w: FloatArray, values: FloatArray) -> FloatArray:
    """``values`` less their weighted mean within each block (columns independently)."""
    sw = np.bincount(block, weights=w)
    sw = np.where(sw > 0, sw, 1.0)
    if values.ndim == 1:
        return values - (np.bincount(block, weights=w * values, minlength=sw.shape[0]) / sw)[block]
    out = np.empty_like(values)
    for j in range(values.shape[1]):
        mean = np.bincount(block, weights=w * values[:, j], minlength=sw.shape[0]) / sw
        out[:, j] = values[:, j] - mean[block]
    return out


def refine(
    pairs: Sequence[PairData],
    positions: Mapping[str, Trajectory | FloatArray],
    start: Mapping[str, float],
    free: Sequence[str],
    block_s: float,
    max_iter: int = 30,
    tolerance_s: float = 1e-4,
) -> Fit:
    """Step 3: Gauss-Newton on eq. (1) for the offsets of ``free`` (the others held at
    ``start``), biases per pair and ``block_s`` block profiled out, Huber weights."""
    t = np.concatenate([p.time_s for p in pairs])
    L = np.concatenate([p.range_m for p in pairs])
    sizes = [p.time_s.shape[0] for p in pairs]
    pair_of = np.repeat(np.arange(len(pairs)), sizes)
    nblk = int(np.ceil((t.max() - t.min()) / block_s)) + 1
    block = pair_of * nblk + ((t - t.min()) // block_s).astype(np.int64)
    ends = [np.repeat([p.a for p in pairs], sizes), np.repeat([p.b for p in pairs], sizes)]
    rows = {pid: [np.flatnonzero(e == pid) for e in ends] for pid in positions}
    tau = {pid: float(start.get(pid, 0.0)) for pid in positions}
    motion = {pid: Motion(v) for pid, v in positions.items() if isinstance(v, Trajectory)}
    index = {pid: j for j, pid in enumerate(free)}
    w = np.ones(t.shape[0])
    scale = np.ones(len(pairs))

    def model() -> tuple[FloatArray, FloatArray]:
        pa, pb = np.empty((t.shape[0], 3)), np.empty((t.shape[0], 3))
        va, vb = np.zeros((t.shape[0], 3)), np.zeros((t.shape[0], 3))
        for pid, (ra, rb) in rows.items():
            src = positions[pid]
            for r, pos, vel in ((ra, pa, va), (rb, pb, vb)):
                if not r.size:
                    continue
                if pid in motion:
                    pos[r], vel[r] = motion[pid].at(t[r] + tau[pid])
                elif not isinstance(src, Trajectory):  # an anchor
                    pos[r] = src
        d, u = slant_ranges_units(pa - pb)
        jac = np.zeros((t.shape[0], len(free)))
        for pid, j in index.items():
            ra, rb = rows[pid]
            jac[ra, j] += np.einsum("ij,ij->i", u[ra], va[ra])
            jac[rb, j] -= np.einsum("ij,ij->i", u[rb], vb[rb])
        return d, jac

    iterations = 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 - reported
        d, jac = model()
        valid = np.isfinite(d) & np.all(np.isfinite(jac), axis=1)
        wv = np.where(valid, w, 0.0)
        r = demean(block, wv, np.where(valid, L - d, 0.0))
        jt = demean(block, wv, np.where(valid[:, None], jac, 0.0))
        # Huber weights on the residual in units of each pair's robust sigma
        for k in range(len(pairs)):
            sel = (pair_of == k) & valid
            if sel.any():
                scale[k] = max(1.4826 * float(np.median(np.abs(r[sel]))), 1e-3)
        z = np.abs(r) / scale[pair_of]
        w = np.where(valid, np.minimum(1.0, HUBER_K / np.maximum(z, 1e-12)), 0.0)
        if not free:
            break
        normal = (jt * w[:, None]).T @ jt
        step = np.linalg.lstsq(normal, (jt * w[:, None]).T @ r, rcond=None)[0]
        step = np.clip(step, -MAX_STEP_S, MAX_STEP_S)  # a trust region: eq. (1) is local
        for pid, j in index.items():
            tau[pid] += float(step[j])
        # converged: every step below the tolerance or a 20th of its (white) 1-sigma
        white = np.sqrt(np.abs(np.diag(np.linalg.pinv(normal))) * float(np.mean(w * r**2)))
        if np.all(np.abs(step) < np.maximum(tolerance_s, white / 20)):
            break
    d, jac = model()
    valid = np.isfinite(d) & np.all(np.isfinite(jac), axis=1)
    wv = np.where(valid, w, 0.0)
    r = demean(block, wv, np.where(valid, L - d, 0.0))
    jt = demean(block, wv, np.where(valid[:, None], jac, 0.0))
    n = int(valid.sum())
    dof = max(n - len(free) - np.unique(block[valid]).shape[0], 1)
    s2 = float(np.sum(wv * r**2)) / dof
    ess = ess_factor(r, wv, pair_of)
    normal = (jt * wv[:, None]).T @ jt
    cov = np.linalg.pinv(normal) * s2 * ess if free else np.zeros((0, 0))
    sw = np.maximum(np.sum(wv), 1e-12)
    raw = np.where(valid[:, None], jac, 0.0)
    slope = {pid: float(np.sqrt(np.sum(wv * raw[:, j] ** 2) / sw)) for pid, j in index.items()}
    count = {pid: int(sum(np.sum(valid[rr]) for rr in rows[pid])) for pid in free}
    return Fit(
        offset_s={pid: tau[pid] for pid in free},
        sigma_s={pid: float(np.sqrt(max(cov[j, j], 0.0))) for pid, j in index.items()},
        slope_mps=slope,
        count=count,
        residual_m=float(np.sqrt(s2)),
        ess_factor=ess,
        iterations=iterations,
        block_s=block_s,
    )


def ess_factor(r: FloatArray, w: FloatArray, pair_of: NDArray[np.int64]) -> float:
    """The effective-sample-size factor of correlated residuals: 1 + 2 sum_k rho_k, the
    integrated autocorrelation of the weighted residuals within the pairs (rows of a pair
    are in time order), the sum ending at the first lag whose rho_k is below
    :data:`ESS_FLOOR` (at most :data:`ESS_MAX_LAG` lags). A white residual gives 1; a
    dead reckoning's drift or a GNSS/INS solution's Gauss-Markov error (2 cm, 10 s:
    docs/simulator.md) tens: the 1-sigma grows by its square root."""
    e = r * np.sqrt(w)
    den = float(np.sum(e**2))
    if den <= 0:
        return 1.0
    factor = 1.0
    for k in range(1, min(ESS_MAX_LAG, e.shape[0] - 1) + 1):
        same = pair_of[k:] == pair_of[:-k]
        rho = float(np.sum((e[k:] * e[:-k])[same])) / den
        if rho < ESS_FLOOR:
            break
        factor += 2.0 * rho
    return factor
