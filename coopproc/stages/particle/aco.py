"""Ant colony optimization resampling, paper 004 step 5 and eq. (14), in O(P x K).

Eq. (14): particle i moves to particle j with probability
P_ij = w_ij^alpha eta_ij^beta / sum_j w_ij^alpha eta_ij^beta, where w_ij is the weight
difference w_j - w_i (only heavier particles attract) and eta_ij = 1 / |p_i - p_j| the
inverse moving distance. If the largest P_ij exceeds lambda, particle i takes the state
of that best j; otherwise it stays.

Approximation (issue 7): the sum over all P = N x M particles is O(P^2) (2.6e10 pairs at
400 x 400). Here j runs over a candidate set of at most K + 9 particles:

- the K heaviest particles of the cloud (they carry the largest weight differences, the
  dominant long-range terms), and
- the heaviest particle of i's own grid cell and of the 8 cells around it (cells of
  ``cell_m``): among the nearby particles, whose eta is large, the heaviest has the
  largest numerator, so it dominates the short-range terms.

The sum in the denominator runs over the same candidates, so P_ij is somewhat larger than
the exact value for the same j; the decision rule (best P_ij against lambda) and the move
target keep their meaning, and particles still climb to nearby heavier particles as the
exact rule makes them do, which keeps the cloud diverse. Cost: O(P) to bin the particles
plus O(P x (K + 9)) for the probabilities. Distances below ``MIN_DISTANCE_M`` are clamped
so that eta stays finite.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.model import FloatArray

__all__ = ["MAX_CELLS", "MIN_DISTANCE_M", "aco_targets", "share_weights", "top_k"]

MIN_DISTANCE_M = 1e-3
#: Upper bound on grid cells; a wider cloud gets larger cells.
MAX_CELLS = 4_000_000


@numba.njit(cache=True)
def _top_k(w: np.ndarray, k: int) -> np.ndarray:  # pragma: no cover - compiled
    """One pass keeping the k heaviest so far sorted (heaviest first, the lower index
    first among equal weights): most particles are rejected by one comparison."""
    out = np.empty(k, dtype=np.int64)
    kept = 0
    for i in range(w.shape[0]):
        wi = w[i]
        if kept == k and not wi > w[out[k - 1]]:
            continue
        c = kept if kept < k else k - 1
        while c > 0 and wi > w[out[c - 1]]:  # equal weights keep the earlier index first
            if c < k:
                out[c] = out[c - 1]
            c -= 1
        out[c] = i
        if kept < k:
            kept += 1
    return out


def top_k(w: FloatArray, k: int) -> np.ndarray:
    """Indices of the ``k`` largest weights, heaviest first (ties broken by index,
    deterministic)."""
    return np.asarray(_top_k(np.ascontiguousarray(w, dtype=float), min(k, w.shape[0])))


@numba.njit(cache=True, inline="always")
def _numerator(dw: float, d2: float, alpha: float, beta: float) -> float:  # pragma: no cover
    """Eq. (14) numerator w_ij^alpha eta_ij^beta, eta = 1 / distance (d2: squared,
    clamped); 0 where j is not heavier than i (it never attracts)."""
    if dw <= 0.0:
        return 0.0
    if alpha == 1.0 and beta == 1.0:
        return dw / np.sqrt(d2)
    return dw**alpha * d2 ** (-0.5 * beta)


@numba.njit(cache=True, fastmath=True)
def _aco_targets(
    east: np.ndarray,
    north: np.ndarray,
    w: np.ndarray,
    cand: np.ndarray,
    e0: float,
    n0: float,
    cell: float,
    alpha: float,
    beta: float,
    lam: float,
    gate: float,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    n_p = east.shape[0]
    n_cand = cand.shape[0]
    # cells of ``cell`` m from (e0, n0), one empty cell of padding on every side so that
    # the 3 x 3 neighbourhood needs no bounds checks
    cx = np.empty(n_p, dtype=np.int32)
    cy = np.empty(n_p, dtype=np.int32)
    nx = 0
    ny = 0
    for i in range(n_p):
        cx[i] = int((east[i] - e0) / cell) + 1
        cy[i] = int((north[i] - n0) / cell) + 1
        nx = max(nx, cx[i] + 2)
        ny = max(ny, cy[i] + 2)
    champ = np.full(nx * ny, -1, dtype=np.int64)
    for i in range(n_p):
        c = cy[i] * nx + cx[i]
        b = champ[c]
        if b < 0 or w[i] > w[b]:
            champ[c] = i
    is_cand = np.zeros(n_p, dtype=np.bool_)
    for c in range(n_cand):
        is_cand[cand[c]] = True
    # each cell's champion (its heaviest particle) by cell, weight 0 where the cell is
    # empty or its champion is a global candidate (counted once, among those): a zero
    # weight never attracts, so the loops below are branch-free
    # (weight, east, north) interleaved: a row of 3 cells is two cache lines
    grid = np.zeros((nx * ny, 3))
    for c in range(nx * ny):
        j = champ[c]
        if j >= 0 and not is_cand[j]:
            grid[c, 0], grid[c, 1], grid[c, 2] = w[j], east[j], north[j]
    # the global candidates' states in contiguous arrays (the loop over them vectorizes)
    ce = np.empty(n_cand)
    cn = np.empty(n_cand)
    cw = np.empty(n_cand)
    for c in range(n_cand):
        ce[c], cn[c], cw[c] = east[cand[c]], north[cand[c]], w[cand[c]]
    min2 = MIN_DISTANCE_M * MIN_DISTANCE_M
    plain = alpha == 1.0 and beta == 1.0
    v = np.empty(n_cand + 9)
    for i in range(n_p):
        wi = w[i]
        if wi >= gate:  # a heavy particle keeps its position
            out[i] = i
            continue
        ei = east[i]
        ni = north[i]
        if plain:
            for c in range(n_cand):
                ex = ei - ce[c]
                ey = ni - cn[c]
                v[c] = max(cw[c] - wi, 0.0) / np.sqrt(max(ex * ex + ey * ey, min2))
        else:
            for c in range(n_cand):
                ex = ei - ce[c]
                ey = ni - cn[c]
                v[c] = _numerator(cw[c] - wi, max(ex * ex + ey * ey, min2), alpha, beta)
        n = n_cand
        for dy in range(-1, 2):
            row = (cy[i] + dy) * nx + cx[i]
            for dx in range(-1, 2):
                c = row + dx
                ex = ei - grid[c, 1]
                ey = ni - grid[c, 2]
                d2 = max(ex * ex + ey * ey, min2)
                if plain:
                    v[n] = max(grid[c, 0] - wi, 0.0) / np.sqrt(d2)
                else:
                    v[n] = _numerator(grid[c, 0] - wi, d2, alpha, beta)
                n += 1
        # the sum and the largest numerator as two reductions that vectorize, then the
        # first candidate that has it
        total = 0.0
        best_v = 0.0
        for c in range(n):
            total += v[c]
            best_v = max(best_v, v[c])
        best = -1
        if best_v > 0.0 and best_v > lam * total:
            best = 0
            while v[best] != best_v:
                best += 1
        if best >= 0:  # P_ij^best > lambda
            if best < n_cand:
                out[i] = cand[best]
            else:  # the champion of the best cell of the 3 x 3 neighbourhood
                k = best - n_cand
                out[i] = champ[(cy[i] + k // 3 - 1) * nx + cx[i] + k % 3 - 1]
        else:
            out[i] = i


def aco_targets(
    east: FloatArray,
    north: FloatArray,
    w: FloatArray,
    k: int,
    alpha: float,
    beta: float,
    lam: float,
    cell_m: float,
    gate: float = 1.0,
) -> np.ndarray:
    """For every particle, the index whose state it takes (itself if it stays).

    ``w`` are the normalized weights; they are rescaled to max 1 first, which leaves
    eq. (14) unchanged (the scale cancels) and avoids underflow of w^alpha. Only particles
    lighter than ``gate`` x the heaviest move ("particles with smaller weight move to the
    optimal position, particles with larger weight keep their position", section 1).
    """
    scale = float(w.max())
    w1 = w / scale if scale > 0 else np.ones_like(w)
    cand = top_k(w1, k)
    e0, n0 = float(east.min()), float(north.min())
    span = max(float(east.max()) - e0, float(north.max()) - n0, cell_m)
    cell = max(cell_m, span / np.sqrt(MAX_CELLS))
    out = np.empty(east.shape[0], dtype=np.int64)
    _aco_targets(
        east, north, w1, cand, e0, n0, cell, float(alpha), float(beta), float(lam), float(gate), out
    )
    return out


def share_weights(w: FloatArray, targets: np.ndarray) -> FloatArray:
    """Weights after the moves: each particle shares its target's weight with its followers.

    A particle that stays keeps its weight, split evenly with the particles that moved
    onto it; the weight of the particles that moved is dropped (it was below the gate);
    the result is normalized (eq. (13)). This keeps the probability mass where it was,
    which the paper's reset to 1 / (N x M) would not (see aacopf.py).
    """
    counts = np.bincount(targets, minlength=w.shape[0]).astype(np.float64)
    out = w[targets] / counts[targets]
    return np.asarray(out / out.sum())
