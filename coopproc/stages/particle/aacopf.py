"""Adaptive ant colony optimization particle filter (AACOPF), paper 004 section 3.

Steps 1-6 and Algorithm 1: ring initialization, eq. (3) propagation, adaptive rejection
of badly ranging auxiliaries (step 3), Gaussian range weights (eq. (11)-(13)), ant
colony resampling (eq. (14), :mod:`coopproc.stages.particle.aco`), the estimate of
eq. (15) and the initial azimuth, eq. (16) (see core.TrackBuilder.record).

Choices where the text is garbled or silent (docs/locate.md explains each):

- Step 3 residuals rho_j = d_1j - E[|x - p_j|] use the predicted range (weighted mean
  over the propagated particles, eq. (11)), not the range from the mean position, which
  is meaningless while the cloud is a ring or multi-modal. Over the last
  ``residual_window`` epochs of the auxiliary, "E[rho_j] > Omega1" is read as |mean|
  (a peak shift may have either sign) and D[rho_j] is the von Neumann estimate (mean
  square successive difference / 2), which cancels the slowly varying error that a
  pulled-off estimate puts into every auxiliary's residuals. The auxiliary with the
  smallest D[rho] is the reference, never rejected (it changes only to one twice as
  consistent); a lone auxiliary is never rejected; an eliminated one stays out until
  its mean and D[rho] are both below the thresholds; one kept although it ranges worse
  than its nominal sigma is down-weighted (sigma widened by its excess variance and,
  when |mean| > Omega1, by its mean).
- With 2+ auxiliaries, until they are judged only the auxiliary that built the ring is
  used (``warmup = "first"``; ``"floor"`` mixes an outlier floor into the others'
  likelihoods instead): a biased auxiliary would otherwise remove the true hypotheses
  in the first seconds, which no later rejection undoes. The PF uses every range.
- The elimination "x_t^i . x < 0 -> w = 0" of step 4 is unreadable; the Gaussian weight
  already gives particles that contradict the range a negligible weight.
- Step 5 resets every weight to 1 / (N x M) after the moves; taken literally this throws
  away the measurement history (the moves follow proximity as much as weight) and the
  filter did not converge. Only particles lighter than ``aco_weight_gate`` x the
  heaviest move (section 1: "particles with smaller weight move to the optimal
  position, particles with larger weight keep their position"); a moved particle shares
  the weight of its target (:func:`share_weights`: mass preserved) and lands near it
  with a kernel jitter (regularized resampling, :func:`kernel_jitter`). Once every
  auxiliary is judged, an effective sample size below ``ess_min`` x N x M triggers a
  systematic resampling that resets the weights to 1 / (N x M), as step 5 does.
- The estimate of eq. (15) is taken with the updated weights before the ACO moves.
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.locate_result import LocateInputs, Track
from coopproc.estimation.range_model import slant_ranges
from coopproc.stages.particle.aco import aco_targets, share_weights
from coopproc.stages.particle.core import (
    TrackBuilder,
    init_cloud,
    normalize_log,
    propagate,
    update_weights,
)
from coopproc.stages.particle.fused import (
    jitter_kernel,
    move_and_jitter,
    posterior_moments,
    resample_and_jitter,
)
from coopproc.stages.particle.modekeep import (
    cancel_cross_mode,
    geometry_separates,
    jitter_by_mode,
    resample_by_mode,
)
from coopproc.stages.particle.modes import find_modes
from coopproc.stages.particle.monitor import AuxMonitor, ranging_noise_m2, ring_auxiliary
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.progress import ProgressFn

__all__ = ["AuxMonitor", "run_aacopf"]  # AuxMonitor: see monitor.py


def run_aacopf(
    inputs: LocateInputs, params: LocateParams, seed: int, progress: ProgressFn | None = None
) -> Track:
    """Run the AACOPF over all epochs of ``inputs``; returns its track."""
    rng = np.random.default_rng(seed)
    n_e, n_j = inputs.range_m.shape
    # several auxiliaries: the ring and the first reference from the quietest (issue 17)
    j_ring = ring_auxiliary(inputs) if n_j > 1 else 0
    quiet = np.array(
        [ranging_noise_m2(inputs.time_s, inputs.range_m[:, j]) <= params.Omega2 for j in range(n_j)]
    )
    cloud = init_cloud(inputs, params, rng, ring=j_ring if n_j > 1 else None)
    builder = TrackBuilder("aacopf", inputs, params, rng)
    rejected = np.zeros((n_e, n_j), dtype=bool)
    monitor = AuxMonitor(n_j, params, ref=j_ring if n_j > 1 else -1)
    # several auxiliaries: one that ranges badly must not remove hypotheses before its
    # residual window has judged it, so until then its likelihood gets an outlier floor
    outlier = params.outlier_sigmas if n_j > 1 and params.warmup == "floor" else 0.0
    nominal_var = np.nanmedian(inputs.sigma_m, axis=0) ** 2 + params.likelihood_floor_m**2
    used = np.zeros((n_e, n_j), dtype=bool)
    keeping = params.mode_keep
    kept_until: float | None = None
    min_particles = max(int(params.mode_min_fraction * cloud.size), 1)
    for t in range(n_e):
        for j_new in np.flatnonzero(np.isfinite(inputs.range_m[t])).tolist():
            monitor.add_range(j_new, float(inputs.time_s[t]), float(inputs.range_m[t, j_new]))
        if t > 0:
            propagate(cloud, inputs, t - 1, params, rng)  # step 2
        if t > 0 and n_j > 1:  # a lone auxiliary is never judged: no residuals needed
            # step 3: residuals of each auxiliary against the predicted range, taken only
            # while the cloud predicts that range to within judge_spread_m
            w_prior = normalize_log(cloud.log_w)
            for j in range(n_j):
                z = inputs.range_m[t, j]
                if np.isfinite(z):
                    ax, ay = inputs.aux_en_m[t, j]
                    d_hat = slant_ranges(np.column_stack([cloud.east - ax, cloud.north - ay]))
                    d_pred = float(w_prior @ d_hat)
                    spread2 = float(w_prior @ (d_hat - d_pred) ** 2)
                    if spread2 <= params.judge_spread_m**2:
                        monitor.add(j, float(z - d_pred))
        use, inflate = monitor.decide(nominal_var)
        if params.warmup in ("first", "quiet") and n_j > 1:
            # until judged, only the ring's auxiliary is used (epoch 0 too: issue 17);
            # "quiet": from epoch 1 also those whose own ranges are quiet (fixed modules)
            early = np.arange(n_j) == j_ring
            if params.warmup == "quiet" and t > 0:
                early |= quiet
            use &= monitor.judged | early
        rejected[t] = ~use & np.isfinite(inputs.range_m[t])
        used[t] = use & np.isfinite(inputs.range_m[t])
        # step 4: weights, eq. (12)-(13)
        w = update_weights(
            cloud,
            inputs,
            t,
            params,
            use=use,
            inflate_m=inflate,
            outlier_sigmas=outlier,
            floor_mask=~monitor.judged,
        )
        # the posterior's weighted moments: eq. (15)'s estimate and the kernel of the
        # jitters after the moves and the resampling (fused.py)
        cos_phi, sin_phi = cloud.trig()
        mean, cov, phi_mean, total = posterior_moments(
            cloud.east, cloud.north, cloud.phi, cos_phi, sin_phi, cloud.scale, w, 1e-12
        )
        builder.record(t, cloud, w, estimate=(mean[0], mean[1], phi_mean))  # step 6
        if progress is not None:
            progress("aacopf", t + 1, n_e)
        if keeping and t % params.mode_every == 0:
            # mode safety (issue 17): label the modes until the geometry, linearized at
            # the heaviest mode, separates them (eq. (19) on the ranges used so far)
            split = find_modes(
                cloud.east, cloud.north, cloud.phi, w, params.mode_cell_m, params.mode_az_deg
            )
            top = split.modes[0]
            if t > 0 and geometry_separates(
                inputs,
                used,
                t,
                float(top.phi_rad - builder.turned[t]),
                top.east_m,
                top.north_m,
                params.observability_tol,
            ):
                keeping, cloud.mode = False, None
                kept_until = float(inputs.time_s[t])
            else:
                labels = split.labels
                cloud.mode = np.where(labels < params.mode_max, labels, -1)
        if t == 0 or not used[t].any():
            continue  # no range used at this epoch: the weights did not change
        # step 5: ant colony resampling, eq. (14), then the moved particles share weights
        idx = aco_targets(
            cloud.east,
            cloud.north,
            w,
            params.aco_candidates,
            params.alpha,
            params.beta,
            params.lambda_,
            params.aco_cell_m,
            params.aco_weight_gate,
        )
        # every auxiliary used now is judged (or the ring's, alone in the warm-up)
        settled = n_j == 1 or bool((monitor.judged | (np.arange(n_j) == j_ring))[used[t]].all())
        if cloud.mode is None:
            chol, h, a = jitter_kernel(cov, cloud.size, params.kernel_scale, params.kernel_shrink)
            if total <= 0:
                h, a = 0.0, 1.0
            east, north, phi, phi0, scale, w, ess = move_and_jitter(
                cloud.east, cloud.north, cloud.phi, cloud.phi0, cloud.scale, w, idx, cloud.noise,
                chol, mean, phi_mean, h, a,
            )  # fmt: skip
            if settled and ess < params.ess_min * cloud.size:
                # degeneracy guard (once every auxiliary is judged): systematic
                # resampling, weights 1 / (N x M) as step 5 says
                east, north, phi, phi0, scale = resample_and_jitter(
                    east, north, phi, phi0, scale, w, float(rng.random()), cloud.noise,
                    chol, mean, phi_mean, h, a,
                )  # fmt: skip
                cloud.log_w = np.full(cloud.size, -np.log(cloud.size))
            else:
                with np.errstate(divide="ignore"):
                    cloud.log_w = np.log(w)
            cloud.cos_phi = cloud.sin_phi = None
            cloud.east, cloud.north, cloud.phi, cloud.phi0, cloud.scale = (
                east,
                north,
                phi,
                phi0,
                scale,
            )
            continue
        # modes kept (mode_keep): the moves and the resampling of each mode on its own
        idx = cancel_cross_mode(idx, cloud.mode)
        w_before = w
        cloud.take(idx)
        w = share_weights(w, idx)
        jitter_by_mode(cloud, w_before, idx != np.arange(cloud.size), params, rng)
        if settled and 1.0 / float(w @ w) < params.ess_min * cloud.size:
            # modes kept: each resampled on its own, none below min_particles
            res, w_new = resample_by_mode(w, cloud.mode, min_particles, rng)
            cloud.take(res)
            dup = np.ones(cloud.size, dtype=bool)
            dup[np.unique(res, return_index=True)[1]] = False  # res not sorted here
            jitter_by_mode(cloud, w_new, dup, params, rng)
            cloud.log_w = np.log(w_new)
        else:
            with np.errstate(divide="ignore"):
                cloud.log_w = np.log(w)
    w = normalize_log(cloud.log_w)
    final = find_modes(
        cloud.east, cloud.north, cloud.phi, w, params.mode_cell_m, params.mode_az_deg
    )
    return builder.build(rejected=rejected, modes=final.modes, modes_kept_until_s=kept_until)
