"""Fused per-epoch kernels of the AACOPF (issue 17, >= 20 steps/s at 400 x 400).

A step of the AACOPF at 160,000 particles used to be a dozen passes over the cloud:
propagation, range likelihood, normalization, the estimate, the weighted moments twice,
the moves, the weight sharing, the resampling, each with numpy temporaries and with
blocks of random numbers drawn beforehand. Here each stage is one compiled pass:

- :func:`range_update`: eq. (11)-(13), the log-likelihood of the ranges used added to
  the log-weights, normalized weights out;
- :func:`move_and_jitter`: step 5's moves (every particle takes its target's state),
  the kernel jitter of the moved ones and the weight sharing, with the effective
  sample size;
- :func:`resample_and_jitter`: the degeneracy guard's systematic resampling, the
  duplicates jittered (first copies exact).

Random numbers are drawn inside the kernels (normal.standard_normal: a ziggurat on a
xoshiro256+ state seeded from the filter's Generator, ``Cloud.noise``), one particle
after another: a seed still gives the same run, byte for byte, but not the runs of the
code before issue 17's speed-up, which drew numpy's normals in blocks.

The kernel of the jitters (:func:`jitter_kernel`) is computed once per epoch from the
weighted moments of the posterior (the cloud and its weights before the moves, the same
pass that gives eq. (15)'s estimate) and serves both the moves and the resampling.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.estimation.range_model import slant_range
from coopproc.model import FloatArray
from coopproc.stages.particle.normal import standard_normal

__all__ = [
    "jitter_kernel",
    "move_and_jitter",
    "posterior_moments",
    "range_update",
    "resample_and_jitter",
]

_TWO_PI = 2.0 * np.pi


def jitter_kernel(
    cov: FloatArray, size: int, kernel_scale: float, shrink: bool
) -> tuple[FloatArray, float, float]:
    """(Cholesky factor, h, Liu-West shrink a) of the regularized-resampling kernel.

    h = kernel_scale x (4 / (P (d + 2)))^(1 / (d + 4)), d = 4 (Musso et al. 2001), at
    most 0.99; the covariance is regularized so that a degenerate cloud still factorizes;
    a = sqrt(1 - h^2) with ``shrink`` (Liu & West 2001), else 1 (see core.kernel_jitter).
    """
    d = 4
    if kernel_scale <= 0:
        return np.zeros((d, d)), 0.0, 1.0
    h = min(kernel_scale * (4.0 / (size * (d + 2))) ** (1.0 / (d + 4)), 0.99)
    scale = np.sqrt(np.maximum(np.diag(cov), 1e-18))
    corr = cov / np.outer(scale, scale) + 1e-9 * np.eye(d)
    chol = np.ascontiguousarray(scale[:, None] * np.linalg.cholesky(corr))
    a = float(np.sqrt(1.0 - h * h)) if shrink else 1.0
    return chol, h, a


@numba.njit(cache=True)
def range_update(
    log_w: np.ndarray,
    east: np.ndarray,
    north: np.ndarray,
    ax: np.ndarray,
    ay: np.ndarray,
    z: np.ndarray,
    s2: np.ndarray,
    floor: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """Add the Gaussian range log-likelihood of the auxiliaries at (ax, ay) with ranges
    ``z`` and variances ``s2`` to ``log_w`` in place; returns the normalized weights.

    ``floor`` (per auxiliary): an outlier floor log-density mixed in (logaddexp), or
    -inf for none (core.log_likelihood's ``outlier_sigmas``)."""
    n = log_w.shape[0]
    top = -np.inf
    diff = np.empty(2)
    for i in range(n):
        acc = 0.0
        for j in range(z.shape[0]):
            diff[0] = east[i] - ax[j]
            diff[1] = north[i] - ay[j]
            d = slant_range(diff, 0.0) - z[j]
            term = -0.5 * d * d / s2[j]
            if floor[j] > -np.inf:
                term = np.logaddexp(term, floor[j])
            acc += term
        lw = log_w[i] + acc
        log_w[i] = lw
        if lw > top:
            top = lw
    w = np.empty(n)
    total = 0.0
    for i in range(n):
        w[i] = np.exp(log_w[i] - top)
        total += w[i]
    for i in range(n):
        w[i] /= total
    return w


@numba.njit(cache=True)
def posterior_moments(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    cos_phi: np.ndarray,
    sin_phi: np.ndarray,
    scale: np.ndarray,
    w: np.ndarray,
    rel: float,
) -> tuple[np.ndarray, np.ndarray, float, float]:  # pragma: no cover - compiled
    """kernels.weighted_moments over the whole cloud with the azimuths' cos and sin
    given (the propagation computed them): weighted mean (4,) and covariance (4, 4) of
    (east, north, azimuth, scale) over the particles heavier than ``rel`` x the
    heaviest, the azimuth about its circular mean; (mean, cov, circular mean, total)."""
    wmax = 0.0
    for i in range(w.shape[0]):
        wmax = max(wmax, w[i])
    cut = rel * wmax
    sw = ss = sc = 0.0
    first = -1
    for i in range(w.shape[0]):
        if w[i] > cut:
            if first < 0:
                first = i
            sw += w[i]
            ss += w[i] * sin_phi[i]
            sc += w[i] * cos_phi[i]
    mean = np.zeros(4)
    cov = np.zeros((4, 4))
    if sw <= 0.0:
        return mean, cov, 0.0, 0.0
    phi_mean = np.arctan2(ss, sc)
    e0, n0, k0 = east[first], north[first], scale[first]
    s1 = np.zeros(4)
    x = np.empty(4)
    for i in range(w.shape[0]):
        if w[i] > cut:
            wi = w[i] / sw
            x[0] = east[i] - e0
            x[1] = north[i] - n0
            x[2] = (phi[i] - phi_mean + np.pi) % _TWO_PI - np.pi
            x[3] = scale[i] - k0
            for a in range(4):
                s1[a] += wi * x[a]
                for b in range(a, 4):
                    cov[a, b] += wi * x[a] * x[b]
    for a in range(4):
        for b in range(a, 4):
            cov[a, b] -= s1[a] * s1[b]
            cov[b, a] = cov[a, b]
    mean[0], mean[1], mean[2], mean[3] = e0 + s1[0], n0 + s1[1], phi_mean + s1[2], k0 + s1[3]
    return mean, cov, phi_mean, sw


@numba.njit(cache=True, inline="always")
def _jitter(
    e: float,
    n: float,
    p: float,
    k: float,
    noise: np.ndarray,
    chol: np.ndarray,
    mean: np.ndarray,
    phi_mean: float,
    h: float,
    a: float,
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """One draw of the kernel around (e, n, p, k): a x source + (1 - a) x mean + h L n."""
    n0 = standard_normal(noise)
    n1 = standard_normal(noise)
    n2 = standard_normal(noise)
    n3 = standard_normal(noise)
    d0 = chol[0, 0] * n0
    d1 = chol[1, 0] * n0 + chol[1, 1] * n1
    d2 = chol[2, 0] * n0 + chol[2, 1] * n1 + chol[2, 2] * n2
    d3 = chol[3, 0] * n0 + chol[3, 1] * n1 + chol[3, 2] * n2 + chol[3, 3] * n3
    if a < 1.0:
        p = ((p - phi_mean + np.pi) % _TWO_PI - np.pi) + phi_mean
        return (
            a * e + (1.0 - a) * mean[0] + h * d0,
            a * n + (1.0 - a) * mean[1] + h * d1,
            a * p + (1.0 - a) * mean[2] + h * d2,
            a * k + (1.0 - a) * mean[3] + h * d3,
        )
    return e + h * d0, n + h * d1, p + h * d2, k + h * d3


@numba.njit(cache=True)
def move_and_jitter(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    phi0: np.ndarray,
    scale: np.ndarray,
    w: np.ndarray,
    idx: np.ndarray,
    noise: np.ndarray,
    chol: np.ndarray,
    mean: np.ndarray,
    phi_mean: float,
    h: float,
    a: float,
) -> tuple[
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float
]:  # pragma: no cover - compiled
    """Particle i takes the state of ``idx[i]``; the moved ones (idx[i] != i) are drawn
    from the kernel around it; weights shared as aco.share_weights does. Returns the new
    (east, north, phi, phi0, scale), the shared normalized weights and their effective
    sample size."""
    size = east.shape[0]
    e2 = np.empty(size)
    n2 = np.empty(size)
    p2 = np.empty(size)
    q2 = np.empty(size)
    k2 = np.empty(size)
    counts = np.zeros(size)
    for i in range(size):
        counts[idx[i]] += 1.0
    w2 = np.empty(size)
    total = 0.0
    for i in range(size):
        j = idx[i]
        q2[i] = phi0[j]
        if j == i:
            e2[i], n2[i], p2[i], k2[i] = east[i], north[i], phi[i], scale[i]
        else:
            e2[i], n2[i], p2[i], k2[i] = _jitter(
                east[j], north[j], phi[j], scale[j], noise, chol, mean, phi_mean, h, a
            )
        w2[i] = w[j] / counts[j]
        total += w2[i]
    sq = 0.0
    for i in range(size):
        w2[i] /= total
        sq += w2[i] * w2[i]
    return e2, n2, p2, q2, k2, w2, 1.0 / sq


@numba.njit(cache=True)
def resample_and_jitter(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    phi0: np.ndarray,
    scale: np.ndarray,
    w: np.ndarray,
    u: float,
    noise: np.ndarray,
    chol: np.ndarray,
    mean: np.ndarray,
    phi_mean: float,
    h: float,
    a: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    """Systematic resampling with one offset ``u`` (as kernels.systematic_indices: for
    slot i the first particle whose cumulative weight exceeds (i + u) / P, the last
    cumulative weight taken as 1); the first copy of a particle exact, the further
    copies drawn from the kernel around it. Returns the new (east, north, phi, phi0,
    scale)."""
    size = east.shape[0]
    e2 = np.empty(size)
    n2 = np.empty(size)
    p2 = np.empty(size)
    q2 = np.empty(size)
    k2 = np.empty(size)
    j = 0
    cdf = w[0] if size > 1 else 1.0
    prev = -1
    for i in range(size):
        pos = (i + u) / size
        while j < size - 1 and cdf <= pos:
            j += 1
            cdf = cdf + w[j] if j < size - 1 else 1.0
        q2[i] = phi0[j]
        if j != prev:
            e2[i], n2[i], p2[i], k2[i] = east[j], north[j], phi[j], scale[j]
        else:
            e2[i], n2[i], p2[i], k2[i] = _jitter(
                east[j], north[j], phi[j], scale[j], noise, chol, mean, phi_mean, h, a
            )
        prev = j
    return e2, n2, p2, q2, k2
