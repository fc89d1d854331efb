"""Modes of a particle cloud: clusters in position and azimuth (issue 17, mode safety).

A cloud that has not decided between hypotheses (the ring of step 1, a mirror image
across the line of two auxiliaries, an azimuth rotated about the auxiliary) holds
several clusters. :func:`find_modes` bins the heaviest particles (those that carry
all but ``1 - mass`` of the weight, at most ``max_particles``) on a grid of
``cell_m`` x ``cell_m`` x ``az_bin_deg`` in (east, north, azimuth) and joins occupied
neighbouring cells (26-connectivity, the azimuth wrapping around) into modes. Every
particle then gets the label of its cell (-1: a cell no heavy particle occupies).

The estimate is *unique* when the runner-up mode's weight is below ``min_weight``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from coopproc.estimation.locate_result import Mode
from coopproc.model import FloatArray

__all__ = ["ModeSplit", "find_modes", "modes_of_hypotheses"]


@dataclass(frozen=True, eq=False)
class ModeSplit:
    """The modes, heaviest first, and the mode label of every particle (-1: none)."""

    modes: tuple[Mode, ...]
    labels: np.ndarray

    def unique(self, min_weight: float) -> bool:
        """True when no second mode weighs ``min_weight`` or more."""
        return len(self.modes) < 2 or self.modes[1].weight < min_weight


def _heavy(w: FloatArray, mass: float, max_particles: int) -> np.ndarray:
    """Indices of the heaviest particles that hold ``mass`` of the weight (capped)."""
    k = min(max_particles, w.shape[0])
    part = np.argpartition(-w, k - 1)[:k]
    part = part[np.argsort(-w[part], kind="stable")]
    cum = np.cumsum(w[part])
    stop = int(np.searchsorted(cum, mass * float(w.sum()))) + 1
    return np.asarray(part[:stop], dtype=np.int64)


def find_modes(
    east: FloatArray,
    north: FloatArray,
    phi: FloatArray,
    w: FloatArray,
    cell_m: float = 2.0,
    az_bin_deg: float = 15.0,
    mass: float = 0.999,
    max_particles: int = 20000,
) -> ModeSplit:
    """Cluster the weighted cloud into modes (see the module docstring)."""
    sel = _heavy(w, mass, max_particles)
    e0, n0 = float(east[sel].min()), float(north[sel].min())
    n_az = max(round(360.0 / az_bin_deg), 1)
    ix = ((east[sel] - e0) / cell_m).astype(np.int64)
    iy = ((north[sel] - n0) / cell_m).astype(np.int64)
    ia = (np.mod(phi[sel], 2.0 * np.pi) / (2.0 * np.pi) * n_az).astype(np.int64) % n_az
    shape = (int(ix.max()) + 1, int(iy.max()) + 1, n_az)
    if shape[0] * shape[1] * shape[2] > 50_000_000:  # a cloud hundreds of metres wide
        cell = cell_m * np.sqrt(shape[0] * shape[1] * shape[2] / 50_000_000)
        return find_modes(east, north, phi, w, cell, az_bin_deg, mass, max_particles)
    grid = np.zeros(shape, dtype=bool)
    grid[ix, iy, ia] = True
    lab, count = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
    if n_az > 2 and count > 1:  # the azimuth wraps: join labels across 0 / 360 degrees
        lab = _join_wrap(lab, count)
    cell_label = lab[ix, iy, ia] - 1
    # labels of every particle: its cell's, -1 outside the occupied cells
    labels = np.full(east.shape[0], -1, dtype=np.int64)
    jx = np.floor((east - e0) / cell_m).astype(np.int64)
    jy = np.floor((north - n0) / cell_m).astype(np.int64)
    ja = (np.mod(phi, 2.0 * np.pi) / (2.0 * np.pi) * n_az).astype(np.int64) % n_az
    inside = (jx >= 0) & (jx < shape[0]) & (jy >= 0) & (jy < shape[1])
    labels[inside] = lab[jx[inside], jy[inside], ja[inside]] - 1
    ids = np.unique(cell_label)
    labels = np.where(labels >= 0, np.searchsorted(ids, labels), -1)
    labels[labels >= ids.shape[0]] = -1
    n_modes = int(ids.shape[0])
    ok = labels >= 0
    lab_ok, w_ok = labels[ok], w[ok]
    weight = np.bincount(lab_ok, w_ok, minlength=n_modes)
    safe = np.where(weight > 0, weight, 1.0)
    mean_e = np.bincount(lab_ok, w_ok * east[ok], minlength=n_modes) / safe
    mean_n = np.bincount(lab_ok, w_ok * north[ok], minlength=n_modes) / safe
    mean_s = np.bincount(lab_ok, w_ok * np.sin(phi[ok]), minlength=n_modes)
    mean_c = np.bincount(lab_ok, w_ok * np.cos(phi[ok]), minlength=n_modes)
    grand = float(w.sum()) or 1.0
    order = np.argsort(-weight, kind="stable")
    order = order[weight[order] > 0]
    remap = np.full(n_modes + 1, -1, dtype=np.int64)  # index -1 maps -1 to -1
    remap[order] = np.arange(order.shape[0])
    modes = tuple(
        Mode(
            weight=float(weight[k]) / grand,
            east_m=float(mean_e[k]),
            north_m=float(mean_n[k]),
            phi_rad=float(np.arctan2(mean_s[k], mean_c[k])),
        )
        for k in order
    )
    return ModeSplit(modes=modes, labels=remap[labels])


def _join_wrap(lab: np.ndarray, count: int) -> np.ndarray:
    """Merge labels that touch across the azimuth seam (bins 0 and last, 3 x 3 cells)."""
    parent = np.arange(count + 1)

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = int(parent[a])
        return a

    first = np.pad(lab[:, :, 0], 1)
    last = lab[:, :, -1]
    nx, ny = last.shape
    for dx in range(3):
        for dy in range(3):
            a = first[dx : dx + nx, dy : dy + ny]
            both = (a > 0) & (last > 0)
            for p, q in zip(a[both].tolist(), last[both].tolist(), strict=True):
                rp, rq = root(p), root(q)
                if rp != rq:
                    parent[max(rp, rq)] = min(rp, rq)
    roots = np.array([root(i) for i in range(count + 1)])
    return np.asarray(roots[lab])


def modes_of_hypotheses(
    east: FloatArray,
    north: FloatArray,
    phi: FloatArray,
    log_lik: FloatArray,
    cell_m: float = 2.0,
    az_bin_deg: float = 15.0,
) -> ModeSplit:
    """Modes of a bank of hypotheses (the EKFs) weighted by their likelihoods."""
    w = np.exp(log_lik - log_lik.max())
    return find_modes(east, north, phi, w / w.sum(), cell_m, az_bin_deg, mass=1.0)
