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


def top_k(w: FloatArray, k: int) -> np.ndarray:
    """Indices of the ``k`` largest weights (ties broken by index, deterministic)."""
    k = min(k, w.shape[0])
    part = np.argpartition(-w, k - 1)[:k]
    return np.asarray(part[np.lexsort((part, -w[part]))], dtype=np.int64)


@numba.njit(cache=True)
def _cell_champions(cx: np.ndarray, cy: np.ndarray, nx: int, ny: int, w: np.ndarray) -> np.ndarray:
    best = np.full(nx * ny, -1, dtype=np.int64)
    for i in range(cx.shape[0]):
        c = cy[i] * nx + cx[i]
        b = best[c]
        if b < 0 or w[i] > w[b]:
            best[c] = i
    return best


@numba.njit(cache=True)
def _aco_targets(
    east: np.ndarray,
    north: np.ndarray,
    w: np.ndarray,
    cand: np.ndarray,
    cx: np.ndarray,
    cy: np.ndarray,
    nx: int,
    ny: int,
    champ: np.ndarray,
    alpha: float,
    beta: float,
    lam: float,
    gate: float,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    n_cand = cand.shape[0]
    is_cand = np.zeros(east.shape[0], dtype=np.bool_)
    for c in range(n_cand):
        is_cand[cand[c]] = True
    local = np.empty(9, dtype=np.int64)
    for i in range(east.shape[0]):
        wi = w[i]
        if wi >= gate:  # a heavy particle keeps its position
            out[i] = i
            continue
        n_local = 0
        for dy in range(-1, 2):
            yy = cy[i] + dy
            if yy < 0 or yy >= ny:
                continue
            for dx in range(-1, 2):
                xx = cx[i] + dx
                if xx < 0 or xx >= nx:
                    continue
                j = champ[yy * nx + xx]
                # a local champion that is also a global candidate counts once
                if j >= 0 and not is_cand[j]:
                    local[n_local] = j
                    n_local += 1
        best = -1
        best_v = 0.0
        total = 0.0
        for c in range(n_cand + n_local):
            j = cand[c] if c < n_cand else local[c - n_cand]
            dw = w[j] - wi
            if dw <= 0.0:
                continue
            ex = east[i] - east[j]
            ey = north[i] - north[j]
            dist = np.sqrt(ex * ex + ey * ey)
            if dist < MIN_DISTANCE_M:
                dist = MIN_DISTANCE_M
            # eq. (14) numerator w_ij^alpha eta_ij^beta, eta = 1 / distance
            a = dw if alpha == 1.0 else dw**alpha
            b = 1.0 / dist if beta == 1.0 else dist ** (-beta)
            v = a * b
            total += v
            if v > best_v:
                best_v = v
                best = j
        if best >= 0 and best_v > lam * total:  # P_ij^best > lambda
            out[i] = best
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
    cx = ((east - e0) / cell).astype(np.int64)
    cy = ((north - n0) / cell).astype(np.int64)
    nx, ny = int(cx.max()) + 1, int(cy.max()) + 1
    champ = _cell_champions(cx, cy, nx, ny, w1)
    out = np.empty(east.shape[0], dtype=np.int64)
    _aco_targets(
        east,
        north,
        w1,
        cand,
        cx,
        cy,
        nx,
        ny,
        champ,
        float(alpha),
        float(beta),
        float(lam),
        float(gate),
        out,
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
