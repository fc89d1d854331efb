"""The offset of a platform's reference against its navigation (:mod:`coopproc.checks.clock`).

A reference whose clock runs ``rho`` seconds ahead of the navigation's shows at its
stamp t the navigation's position at t - rho:

    R(t) = Rot(theta) P(t - rho) + bias + noise                                      (3)

``Rot`` a rotation about the vertical (a dead reckoning in a frame of its own,
:mod:`coopproc.checks.framecheck`; 0 for navigation in the session frame). Coarse: the
complex horizontal velocities (east + i north) of both, cross-correlated over every lag
(:func:`coopproc.checks.clock_fit.lag_correlation`; the modulus is blind to theta, the
phase at the peak gives it). Refinement: Gauss-Newton on (3) for rho with a 3-D bias per
block (the navigation's drift), Huber weights on the residual's length, the block of
:data:`~coopproc.checks.clock_refine.BLOCKS_S` with the smallest 1-sigma kept, the 1-sigma
inflated by the AR(1) effective-sample-size factor of the residuals (as for the ranges).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coopproc.checks.clock_fit import _best, _on_grid, _rate, grid_step, lag_correlation
from coopproc.checks.clock_refine import BLOCKS_S, HUBER_K, Motion, demean, ess_factor
from coopproc.model import FloatArray, Trajectory

__all__ = ["RefFit", "reference_offset"]

#: Shortest overlap of navigation and reference worth an estimate, s.
MIN_REF_OVERLAP_S = 30.0
#: The refinement on at most this many reference epochs (whole windows of 600 s, evenly
#: spread): a day's 430 000 epochs at 5 Hz show the constant offset no better.
MAX_REF_EPOCHS = 10_000
_WINDOW_S = 600.0


@dataclass(frozen=True)
class RefFit:
    """The offset of a reference against its navigation, eq. (3)."""

    offset_s: float
    sigma_s: float
    #: RMS speed of the navigation, m/s
    slope_mps: float
    #: reference epochs used
    count: int
    #: rotation of the navigation's frame found, deg
    theta_deg: float
    block_s: float


def _complex_velocity(traj: Trajectory, grid: FloatArray, step_s: float) -> FloatArray:
    east = _rate(_on_grid(traj.time_s, traj.enu_m[:, 0], grid, traj.gap_limit_s()), step_s)
    north = _rate(_on_grid(traj.time_s, traj.enu_m[:, 1], grid, traj.gap_limit_s()), step_s)
    return east + 1j * north  # type: ignore[no-any-return]


def reference_offset(nav: Trajectory, ref: Trajectory) -> RefFit | None:
    """rho of eq. (3), None when the two do not overlap long enough."""
    if len(nav) < 4 or len(ref) < 4:
        return None
    lo = min(nav.span_s[0], ref.span_s[0])
    hi = max(nav.span_s[1], ref.span_s[1])
    if min(nav.span_s[1], ref.span_s[1]) - max(nav.span_s[0], ref.span_s[0]) < MIN_REF_OVERLAP_S:
        return None
    h = grid_step(hi - lo)
    grid = np.arange(lo, hi + h, h)
    vn, vr = _complex_velocity(nav, grid, h), _complex_velocity(ref, grid, h)
    peak = _best(*lag_correlation([vn], [vr], h, complex_=True), h)
    if peak is None:
        return None
    rho = peak.lag_s
    good = []
    motion = Motion(nav)
    ref = _subset(ref)
    for block in BLOCKS_S:  # each from the last one's offset: a few iterations
        fit = _refine(motion, ref, rho, block)
        if fit is not None:
            good.append(fit)
            rho = fit.offset_s
    return min(good, key=lambda f: f.sigma_s) if good else None


def _subset(ref: Trajectory) -> Trajectory:
    """At most :data:`MAX_REF_EPOCHS` epochs of ``ref``, in whole windows spread evenly."""
    n = len(ref)
    if n <= MAX_REF_EPOCHS:
        return ref
    t = ref.time_s
    windows = max(1, int(np.ceil((t[-1] - t[0]) / _WINDOW_S * MAX_REF_EPOCHS / n)))
    starts = np.linspace(t[0], max(t[0], t[-1] - _WINDOW_S), windows)
    k = np.searchsorted(starts, t, side="right") - 1
    keep = np.flatnonzero((k >= 0) & (t - starts[np.maximum(k, 0)] < _WINDOW_S))
    return Trajectory(ref.platform, t[keep], ref.enu_m[keep], source=ref.source)


def _refine(
    nav: Motion, ref: Trajectory, rho: float, block_s: float, max_iter: int = 30
) -> RefFit | None:
    t, r_enu = ref.time_s, ref.enu_m
    block = ((t - t[0]) // block_s).astype(np.int64)
    w = np.ones(t.shape[0])
    theta = 0.0
    iterations_left = max_iter
    while True:
        at = t - rho
        p, v = nav.at(at)
        valid = np.isfinite(p[:, 0]) & np.isfinite(r_enu[:, 0])
        if valid.sum() < 10:
            return None
        wv = np.where(valid, w, 0.0)
        pc = np.where(valid[:, None], p, 0.0)
        rc = np.where(valid[:, None], r_enu, 0.0)
        vc = np.where(valid[:, None], v, 0.0)
        # the rotation about the vertical (weighted Procrustes of the block-demeaned tracks)
        pd_, rd = demean(block, wv, pc), demean(block, wv, rc)
        pz = pd_[:, 0] + 1j * pd_[:, 1]
        rz = rd[:, 0] + 1j * rd[:, 1]
        theta = float(np.angle(np.sum(wv * rz * np.conj(pz))))
        rot = np.exp(1j * theta)
        model_z = rot * pz
        vz = rot * (vc[:, 0] + 1j * vc[:, 1])
        e = np.column_stack([rz.real - model_z.real, rz.imag - model_z.imag, rd[:, 2] - pd_[:, 2]])
        jac = demean(block, wv, np.column_stack([vz.real, vz.imag, vc[:, 2]]))
        size = np.linalg.norm(e, axis=1)
        scale = max(1.4826 * float(np.median(size[valid])), 1e-4)
        w = np.where(valid, np.minimum(1.0, HUBER_K * scale / np.maximum(size, 1e-12)), 0.0)
        info = float(np.sum(w[:, None] * jac**2))
        if info <= 0:
            return None
        # e(rho + delta) = e + J delta: the model's P(t - rho) moves by -V delta
        step = -float(np.sum(w[:, None] * jac * e)) / info
        rho += step
        iterations_left -= 1
        white = np.sqrt(float(np.mean(w[:, None] * e**2)) * 3.0 / info)
        if abs(step) < max(1e-4, white / 20) or iterations_left == 0:
            break
    n = int(valid.sum())
    dof = max(3 * n - 1 - 3 * np.unique(block[valid]).shape[0], 1)
    s2 = float(np.sum(w[:, None] * e**2)) / dof
    ess = max(ess_factor(e[:, k], w, np.zeros(t.shape[0], dtype=np.int64)) for k in range(3))
    speed = np.where(valid, np.linalg.norm(vc, axis=1), 0.0)
    slope = float(np.sqrt(np.sum(w * speed**2) / max(float(np.sum(w)), 1e-12)))
    return RefFit(
        offset_s=rho,
        sigma_s=float(np.sqrt(s2 * ess / info)),
        slope_mps=slope,
        count=n,
        theta_deg=float(np.degrees(theta)),
        block_s=block_s,
    )
