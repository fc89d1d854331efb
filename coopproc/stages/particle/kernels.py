"""Numba kernels of the particle filters' per-epoch work (issue 17, speed).

At 400 x 400 = 160,000 particles every numpy expression of a step is a pass over the
cloud plus a temporary array; the propagation, the weighted moments behind the kernel
jitter and the estimate of eq. (15) took about 60 % of an AACOPF step. These kernels
do each in one pass without temporaries. The propagation draws its random numbers inside
the kernel (normal.standard_normal, seeded from the filter's Generator), one particle
after another, so a seed gives the same cloud (fused.py has the AACOPF's
other per-epoch passes).
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.stages.particle.normal import standard_normal

__all__ = [
    "jitter_apply",
    "propagate_kernel",
    "systematic_indices",
    "weighted_estimate",
    "weighted_moments",
]

_TWO_PI = 2.0 * np.pi


@numba.njit(cache=True, inline="always")
def _wrap(a: float) -> float:  # pragma: no cover - compiled
    return (a + np.pi) % _TWO_PI - np.pi


@numba.njit(cache=True)
def propagate_kernel(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    scale: np.ndarray,
    noise: np.ndarray,
    delta_l: float,
    delta_phi: float,
    sigma_xy: float,
    sigma_phi: float,
    cos_phi: np.ndarray,
    sin_phi: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Eq. (3) with process noise, in place (see core.propagate); the three standard
    normals of a particle (azimuth, east, north) drawn in turn from the generator
    state ``noise`` (normal.standard_normal); the cosine and sine of each new azimuth
    into ``cos_phi`` and ``sin_phi`` (the posterior's circular mean needs them)."""
    for i in range(east.shape[0]):
        p = phi[i] + delta_phi + sigma_phi * standard_normal(noise)
        phi[i] = p
        c = np.cos(p)
        sn = np.sin(p)
        cos_phi[i] = c
        sin_phi[i] = sn
        step = delta_l * (1.0 + scale[i])
        east[i] += step * c + sigma_xy * standard_normal(noise)
        north[i] += step * sn + sigma_xy * standard_normal(noise)


@numba.njit(cache=True)
def weighted_estimate(
    east: np.ndarray, north: np.ndarray, phi: np.ndarray, w: np.ndarray, rel: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Weighted mean east, north and circular mean azimuth over the particles heavier
    than ``rel`` x the heaviest (eq. (15); the lighter change nothing at float precision)."""
    wmax = 0.0
    for i in range(w.shape[0]):
        if w[i] > wmax:
            wmax = w[i]
    cut = rel * wmax
    sw = se = sn = ss = sc = 0.0
    for i in range(w.shape[0]):
        wi = w[i]
        if wi > cut:
            sw += wi
            se += wi * east[i]
            sn += wi * north[i]
            ss += wi * np.sin(phi[i])
            sc += wi * np.cos(phi[i])
    return se / sw, sn / sw, np.arctan2(ss / sw, sc / sw)


@numba.njit(cache=True)
def weighted_moments(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    scale: np.ndarray,
    w: np.ndarray,
    members: np.ndarray,
    use_members: bool,
    rel: float,
) -> tuple[np.ndarray, np.ndarray, float, float]:  # pragma: no cover - compiled
    """Weighted mean (4,) and covariance (4, 4) of (east, north, azimuth, scale) over the
    particles heavier than ``rel`` x the heaviest (and in ``members`` if used); the
    azimuth unwrapped around its circular mean. Returns (mean, cov, phi_mean, total).

    The products are taken about the first counted particle (a shift of the data), so
    the one-pass sums lose nothing at 1e5 m coordinates."""
    wmax = 0.0
    for i in range(w.shape[0]):
        if w[i] > wmax:
            wmax = w[i]
    cut = rel * wmax
    sw = ss = sc = 0.0
    first = -1
    for i in range(w.shape[0]):
        if w[i] > cut and (not use_members or members[i]):
            if first < 0:
                first = i
            sw += w[i]
            ss += w[i] * np.sin(phi[i])
            sc += w[i] * np.cos(phi[i])
    mean = np.zeros(4)
    cov = np.zeros((4, 4))
    if sw <= 0.0:
        return mean, cov, 0.0, 0.0
    phi_mean = np.arctan2(ss, sc)
    ref = np.empty(4)
    ref[0], ref[1], ref[2], ref[3] = east[first], north[first], 0.0, scale[first]
    s1 = np.zeros(4)
    x = np.empty(4)
    for i in range(w.shape[0]):
        if w[i] > cut and (not use_members or members[i]):
            wi = w[i] / sw
            d = phi[i] - phi_mean
            while d > np.pi:
                d -= _TWO_PI
            while d < -np.pi:
                d += _TWO_PI
            x[0] = east[i] - ref[0]
            x[1] = north[i] - ref[1]
            x[2] = d
            x[3] = scale[i] - ref[3]
            for a in range(4):
                s1[a] += wi * x[a]
                for b in range(a, 4):
                    cov[a, b] += wi * x[a] * x[b]
    for a in range(4):
        for b in range(a, 4):
            cov[a, b] -= s1[a] * s1[b]
            cov[b, a] = cov[a, b]
        mean[a] = ref[a] + s1[a]
    mean[2] += phi_mean
    return mean, cov, phi_mean, sw


@numba.njit(cache=True)
def systematic_indices(cdf: np.ndarray, u: float) -> np.ndarray:  # pragma: no cover - compiled
    """Systematic resampling: for i = 0..P-1 the first index whose ``cdf`` exceeds
    (i + u) / P, i.e. numpy's searchsorted(cdf, positions, side='right') in one merge
    pass over the sorted positions."""
    n = cdf.shape[0]
    out = np.empty(n, dtype=np.int64)
    j = 0
    for i in range(n):
        pos = (i + u) / n
        while j < n and cdf[j] <= pos:
            j += 1
        out[i] = j
    return out


@numba.njit(cache=True)
def jitter_apply(
    east: np.ndarray,
    north: np.ndarray,
    phi: np.ndarray,
    scale: np.ndarray,
    moved: np.ndarray,
    noise: np.ndarray,
    chol: np.ndarray,
    mean: np.ndarray,
    phi_mean: float,
    h: float,
    shrink: float,
) -> None:  # pragma: no cover - compiled
    """Moved particle i (the k-th True of ``moved``) <- shrink x source + (1 - shrink) x
    mean + h chol noise[:, k]; ``shrink`` 1: no Liu-West shrinkage (azimuth then as is)."""
    k = 0
    for i in range(east.shape[0]):
        if not moved[i]:
            continue
        n0, n1, n2, n3 = noise[0, k], noise[1, k], noise[2, k], noise[3, k]
        d0 = chol[0, 0] * n0
        d1 = chol[1, 0] * n0 + chol[1, 1] * n1
        d2 = chol[2, 0] * n0 + chol[2, 1] * n1 + chol[2, 2] * n2
        d3 = chol[3, 0] * n0 + chol[3, 1] * n1 + chol[3, 2] * n2 + chol[3, 3] * n3
        if shrink < 1.0:
            p = _wrap(phi[i] - phi_mean) + phi_mean
            east[i] = shrink * east[i] + (1.0 - shrink) * mean[0] + h * d0
            north[i] = shrink * north[i] + (1.0 - shrink) * mean[1] + h * d1
            phi[i] = shrink * p + (1.0 - shrink) * mean[2] + h * d2
            scale[i] = shrink * scale[i] + (1.0 - shrink) * mean[3] + h * d3
        else:
            east[i] += h * d0
            north[i] += h * d1
            phi[i] += h * d2
            scale[i] += h * d3
        k += 1
