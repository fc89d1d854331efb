"""Particle-cloud building blocks shared by the AACOPF and the standard PF (paper 004).

A particle is (east, north, phi, k): a position, the current azimuth phi (math angle,
rad) and the odometer scale error k of its dead reckoning (see :func:`propagate`).
Particle r = n * M + i starts at position n of the ring and initial azimuth i, so
``r mod M`` is its initial-azimuth index (eq. (16)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coopproc.estimation.angles import wrap_pi
from coopproc.estimation.locate_result import LocateInputs, Mode, Track
from coopproc.model import FloatArray
from coopproc.stages.particle.fused import range_update
from coopproc.stages.particle.kernels import (
    jitter_apply,
    propagate_kernel,
    weighted_estimate,
    weighted_moments,
)
from coopproc.stages.particle.normal import seed_state
from coopproc.stages.particle.params import LocateParams

__all__ = [
    "Cloud",
    "TrackBuilder",
    "init_cloud",
    "kernel_jitter",
    "normalize_log",
    "propagate",
    "update_weights",
]


@dataclass(eq=False)
class Cloud:
    """The particles of one filter; arrays of length P = N x M, updated in place."""

    east: FloatArray
    north: FloatArray
    phi: FloatArray
    log_w: FloatArray
    #: Initial azimuth of each particle's lineage (math angle, rad), eq. (16).
    phi0: FloatArray
    #: Odometer scale error k of each particle: a step moves (1 + k) Delta L (see propagate).
    scale: FloatArray
    #: Mode label of each particle (modes.find_modes; -1 none), None when not tracked.
    mode: np.ndarray | None = None
    #: State of the compiled kernels' random numbers (normal.seed_state, from the
    #: filter's Generator at step 1): process noise and kernel jitter.
    noise: np.ndarray = field(default_factory=lambda: np.ones(4, dtype=np.uint64))
    #: cos and sin of ``phi`` where known (set by :func:`propagate`; None after a move).
    cos_phi: FloatArray | None = None
    sin_phi: FloatArray | None = None

    def trig(self) -> tuple[FloatArray, FloatArray]:
        """(cos phi, sin phi) of the current azimuths."""
        if self.cos_phi is None or self.sin_phi is None:
            self.cos_phi, self.sin_phi = np.cos(self.phi), np.sin(self.phi)
        return self.cos_phi, self.sin_phi

    @property
    def size(self) -> int:
        return int(self.east.shape[0])

    def take(self, idx: np.ndarray) -> None:
        """Every particle takes the state of particle ``idx[i]`` (resampling, ACO moves)."""
        self.east = self.east[idx]
        self.north = self.north[idx]
        self.phi = self.phi[idx]
        self.phi0 = self.phi0[idx]
        self.scale = self.scale[idx]
        self.cos_phi = self.sin_phi = None
        if self.mode is not None:
            self.mode = self.mode[idx]


def init_cloud(
    inputs: LocateInputs, params: LocateParams, rng: np.random.Generator, ring: int | None = None
) -> Cloud:
    """Step 1: N positions on the ring d(1) +- delta_d around the aux, times M azimuths.

    Positions and azimuths are evenly spread with a seeded random offset in each slot
    ("random generation" in the paper); weights uniform, 1 / (N x M). The ring is
    around the auxiliary of the first epoch's first range, or around auxiliary ``ring``
    at its first range, widened by the target's dead-reckoned path since epoch 0.
    """
    n, m = params.N, params.M
    center, d1 = inputs.first_fix()
    half = params.delta_d_m
    if ring is not None:
        k0 = int(np.argmax(np.isfinite(inputs.range_m[:, ring])))
        center, d1 = inputs.aux_en_m[k0, ring], float(inputs.range_m[k0, ring])
        half += float(inputs.increments.delta_l_m[:k0].sum())
    bearing = (np.arange(n) + rng.random(n)) * (2.0 * np.pi / n)
    radius = np.maximum(d1 + rng.uniform(-half, half, n), 0.0)
    azimuth = (np.arange(m) + rng.random(m)) * (2.0 * np.pi / m)
    east = np.repeat(center[0] + radius * np.cos(bearing), m)
    north = np.repeat(center[1] + radius * np.sin(bearing), m)
    phi = np.tile(azimuth, n)
    log_w = np.full(n * m, -np.log(n * m))
    # odometer scale error of each particle, drawn from its prior (0: eq. (3) exactly)
    scale = params.odometer_scale_sigma * rng.standard_normal(n * m)
    return Cloud(
        east=east,
        north=north,
        phi=phi,
        log_w=log_w,
        phi0=phi.copy(),
        scale=scale,
        noise=seed_state(rng),
    )


def propagate(
    cloud: Cloud, inputs: LocateInputs, k: int, params: LocateParams, rng: np.random.Generator
) -> None:
    """Step 2: move every particle from epoch k to k + 1 by eq. (3) plus process noise.

    Algorithm 1, lines 7-8: phi += Delta phi; x += Delta L cos(phi); y += Delta L sin(phi),
    with Delta L scaled by the particle's odometer scale error, (1 + k) Delta L: a
    dead-reckoned path is not rigid, its length is off by the odometer's scale factor
    (0.1-0.5 %), which over the 100-300 m a single auxiliary needs to fix the rotation
    is 0.3-1 m, more than the ranges allow. Eq. (3) has no such term; k is a constant
    per particle, drawn from N(0, odometer_scale_sigma^2) at step 1 (0 restores eq. (3)).
    The importance density is this transition prior, so eq. (12) reduces to
    w_t = w_{t-1} p(z_t | x_t).
    """
    inc = inputs.increments
    delta_l = float(inc.delta_l_m[k])
    root_dt = float(np.sqrt(max(inc.time_s[k + 1] - inc.time_s[k], 0.0)))
    sigma_xy = params.step_sigma_m * root_dt + params.step_sigma_rel * delta_l
    sigma_phi = float(np.radians(params.heading_sigma_deg)) * root_dt
    cos_phi, sin_phi = np.empty(cloud.size), np.empty(cloud.size)
    propagate_kernel(
        cloud.east,
        cloud.north,
        cloud.phi,
        cloud.scale,
        cloud.noise,
        delta_l,
        float(inc.delta_phi_rad[k]),
        sigma_xy,
        sigma_phi,
        cos_phi,
        sin_phi,
    )
    cloud.cos_phi, cloud.sin_phi = cos_phi, sin_phi


def kernel_jitter(
    cloud: Cloud,
    w: FloatArray,
    moved: np.ndarray,
    params: LocateParams,
    rng: np.random.Generator,
    members: np.ndarray | None = None,
) -> None:
    """Regularized resampling: moved (copied) particles land near their source.

    Each particle with ``moved`` True is redrawn from a Gaussian kernel around its source
    whose covariance is h^2 x the cloud's weighted covariance of (east, north, azimuth,
    odometer scale), with the optimal bandwidth
    h = kernel_scale x (4 / (P (d + 2)))^(1 / (d + 4)), d = 4
    (Musso et al. 2001). The full covariance keeps the kernel on the posterior's
    correlation between position and azimuth (a rotation about the auxiliary moves both).
    With ``kernel_shrink`` the kernel is centred on a x source + (1 - a) x mean,
    a = sqrt(1 - h^2) (Liu & West 2001), so the jitter does not add h^2 of the cloud's
    variance at every resampling: without it that inflation balances the little
    information an epoch brings on the weakly observable rotation about the auxiliary,
    and the cloud stalls metres wide. Particles that did not move keep their paths.
    ``members`` (bool, P): the covariance and mean of these particles only (one mode of
    a multi-modal cloud, issue 17: the whole cloud's would throw the moved particles
    between the modes).
    """
    count = int(moved.sum())
    if count == 0 or params.kernel_scale <= 0:
        return
    d = 4
    h = params.kernel_scale * (4.0 / (cloud.size * (d + 2))) ** (1.0 / (d + 4))
    h = min(h, 0.99)
    use_members = members is not None
    mean, cov, phi_mean, total = weighted_moments(
        cloud.east,
        cloud.north,
        cloud.phi,
        cloud.scale,
        w,
        members if members is not None else np.zeros(1, dtype=bool),
        use_members,
        1e-12,
    )
    if total <= 0:
        return
    # Cholesky of the covariance, regularized so a degenerate cloud still factorizes
    scale = np.sqrt(np.maximum(np.diag(cov), 1e-18))
    corr = cov / np.outer(scale, scale) + 1e-9 * np.eye(d)
    chol = scale[:, None] * np.linalg.cholesky(corr)
    noise = rng.standard_normal((d, count))
    shrink = float(np.sqrt(1.0 - h * h)) if params.kernel_shrink else 1.0
    jitter_apply(
        cloud.east,
        cloud.north,
        cloud.phi,
        cloud.scale,
        moved,
        noise,
        np.ascontiguousarray(chol),
        mean,
        phi_mean,
        h,
        shrink,
    )


def update_weights(
    cloud: Cloud,
    inputs: LocateInputs,
    k: int,
    params: LocateParams,
    use: np.ndarray | None = None,
    inflate_m: FloatArray | None = None,
    outlier_sigmas: float = 0.0,
    floor_mask: np.ndarray | None = None,
) -> FloatArray:
    """Eq. (12)-(13): add the ranges' log-likelihood at epoch k to ``cloud.log_w`` (in
    place) and return the normalized weights.

    Gaussian range log-likelihood, summed over the auxiliaries used at epoch k: eq. (11)
    predicted distance per particle, Algorithm 1 line 12 weight
    exp(-sum_j (d_hat - d_1j)^2 / (2 s_j^2)) with s_j^2 = sigma_j^2 + floor^2 (+ inflate_j^2).
    ``outlier_sigmas`` > 0 mixes in a flat outlier floor per auxiliary, exp(-k^2 / 2) with
    k = outlier_sigmas: one range that disagrees by more than k sigma then costs at most
    that factor instead of removing the particle; ``floor_mask`` (J,) limits the floor to
    some auxiliaries.
    """
    js = [
        j
        for j in range(inputs.range_m.shape[1])
        if np.isfinite(inputs.range_m[k, j]) and (use is None or use[j])
    ]
    s2 = inputs.sigma_m[k, js] ** 2 + params.likelihood_floor_m**2
    if inflate_m is not None:
        s2 = s2 + np.asarray(inflate_m, dtype=float)[js] ** 2
    floor = np.full(len(js), -np.inf)
    if outlier_sigmas > 0:
        mask = np.ones(len(js), dtype=bool) if floor_mask is None else floor_mask[js]
        floor[mask] = -0.5 * outlier_sigmas**2
    aux = inputs.aux_en_m[k, js]
    return range_update(
        cloud.log_w,
        cloud.east,
        cloud.north,
        np.ascontiguousarray(aux[:, 0], dtype=float),
        np.ascontiguousarray(aux[:, 1], dtype=float),
        np.ascontiguousarray(inputs.range_m[k, js], dtype=float),
        np.ascontiguousarray(s2, dtype=float),
        floor,
    )


def normalize_log(log_w: FloatArray) -> FloatArray:
    """Normalized weights, eq. (13), from log-weights (max subtracted first)."""
    w = np.exp(log_w - log_w.max())
    return np.asarray(w / w.sum())


def _circular_mean(w: FloatArray, angle_rad: FloatArray) -> float:
    """Weighted circular mean of angles (rad)."""
    return float(np.arctan2(w @ np.sin(angle_rad), w @ np.cos(angle_rad)))


class TrackBuilder:
    """Collects per-epoch estimates (eq. (15)) and particle-cloud snapshots."""

    def __init__(
        self, method: str, inputs: LocateInputs, params: LocateParams, rng: np.random.Generator
    ) -> None:
        e = inputs.n_epochs
        self.method = method
        self.inputs = inputs
        self.east = np.empty(e)
        self.north = np.empty(e)
        self.phi = np.empty(e)
        count = min(params.snapshots, e)
        self.snap_epochs = (
            set(np.unique(np.geomspace(1, e, count).astype(int) - 1).tolist()) if count else set()
        )
        size = params.N * params.M
        keep = min(params.snapshot_particles, size)
        self.snap_index = np.sort(rng.choice(size, size=keep, replace=False))
        self.snapshots: list[tuple[float, FloatArray]] = []
        self.best_phi0 = 0.0
        # own-frame azimuth change since epoch 0: phi(t) - turned(t) is the initial azimuth
        # that a particle's current azimuth implies
        inc = inputs.increments
        self.turned = inc.heading_own_rad() - inc.theta0_rad
        self.mean_implied = np.empty(e)

    def record(
        self,
        k: int,
        cloud: Cloud,
        w: FloatArray,
        estimate: tuple[float, float, float] | None = None,
    ) -> None:
        """Eq. (15) weighted mean position, circular weighted mean azimuth at epoch k.

        Particles lighter than 1e-12 x the heaviest are left out of the sums (they change
        them by less than the float precision of the output). ``estimate``: (east, north,
        azimuth) already computed so (kernels.weighted_moments, the same sums).
        """
        if estimate is None:
            estimate = weighted_estimate(cloud.east, cloud.north, cloud.phi, w, 1e-12)
        e, n, p = estimate
        self.east[k], self.north[k], self.phi[k] = e, n, p
        # eq. (16) literally: the initial azimuth of the largest-weight particle's lineage
        # (index r mod M of the initial grid). With process noise on the azimuth a lineage
        # keeps its grid value while its azimuth wanders, so the reported initial azimuth
        # is the one the estimated azimuth implies: phi_hat(t) minus the own-frame turn
        # since epoch 0 (weighted like eq. (15)); measured closer to the truth in tests.
        r = int(np.argmax(w))
        self.best_phi0 = float(wrap_pi(cloud.phi0[r]))
        self.mean_implied[k] = float(wrap_pi(self.phi[k] - self.turned[k]))
        if k in self.snap_epochs:
            pts = np.column_stack([cloud.east[self.snap_index], cloud.north[self.snap_index]])
            self.snapshots.append((float(self.inputs.time_s[k]), pts))

    def build(
        self,
        rejected: np.ndarray | None = None,
        modes: tuple[Mode, ...] = (),
        modes_kept_until_s: float | None = None,
    ) -> Track:
        return Track(
            method=self.method,
            time_s=self.inputs.time_s,
            east_m=self.east,
            north_m=self.north,
            phi_rad=wrap_pi(self.phi),
            initial_azimuth_track_rad=wrap_pi(self.mean_implied),
            initial_azimuth_rad=float(self.mean_implied[-1]),
            initial_azimuth_eq16_rad=self.best_phi0,
            snapshots=tuple(self.snapshots),
            rejected=rejected,
            modes=modes,
            modes_kept_until_s=modes_kept_until_s,
        )
