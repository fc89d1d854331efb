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

from coopproc.stages.particle.aco import aco_targets, share_weights
from coopproc.stages.particle.core import (
    Track,
    TrackBuilder,
    init_cloud,
    kernel_jitter,
    log_likelihood,
    normalize_log,
    propagate,
)
from coopproc.stages.particle.inputs import LocateInputs
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.pf import systematic_resample

__all__ = ["AuxMonitor", "run_aacopf"]


class AuxMonitor:
    """Step 3: per-auxiliary residual windows and the reject / down-weight decision."""

    def __init__(self, n_aux: int, params: LocateParams) -> None:
        self.window = params.residual_window
        self.buf = np.full((n_aux, self.window), np.nan)
        self.count = np.zeros(n_aux, dtype=np.int64)
        self.omega1 = params.Omega1
        self.omega2 = params.Omega2
        #: Auxiliaries whose last decision was made on a full window next to another one.
        self.judged = np.zeros(n_aux, dtype=bool)
        #: The reference auxiliary (smallest D[rho]), -1 before the first decision.
        self.ref = -1
        #: Eliminated auxiliaries; one stays out until its window is clean again.
        self.out = np.zeros(n_aux, dtype=bool)

    def add(self, j: int, residual_m: float) -> None:
        self.buf[j, self.count[j] % self.window] = residual_m
        self.count[j] += 1

    def decide(self, nominal_var_m2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(use (J,) bool, inflate_m (J,)) from the current residual windows.

        Only auxiliaries with a full window are judged, and only when at least two are:
        a lone auxiliary is never rejected (the filter would be blind). The auxiliary
        with the smallest residual variance is the reference and is always used as is.
        Another one is rejected when |mean| > Omega1 and variance > Omega2 (paper); if
        kept, its likelihood sigma is widened by its excess variance and, when its
        |mean| > Omega1, by its mean (down-weighting).
        """
        n_aux = self.buf.shape[0]
        use = np.ones(n_aux, dtype=bool)
        inflate = np.zeros(n_aux)
        full = self.count >= self.window
        self.judged = full if full.sum() >= 2 else np.zeros(n_aux, dtype=bool)
        if full.sum() < 2:
            return use, inflate
        # buffer in time order, to difference successive residuals
        order = (self.count[:, None] + np.arange(self.window)[None, :]) % self.window
        buf = np.take_along_axis(np.where(full[:, None], self.buf, 0.0), order, axis=1)
        mean = np.where(full, buf.mean(axis=1), 0.0)
        # D[rho] from successive differences (var(diff) / 2): the slowly varying error of
        # the estimate itself cancels, the auxiliary's own ranging noise stays
        var = np.where(full, 0.5 * np.mean(np.diff(buf, axis=1) ** 2, axis=1), 0.0)
        # the reference changes only to an auxiliary at least twice as consistent
        cand = int(np.argmin(np.where(full, var, np.inf)))
        if self.ref < 0 or not full[self.ref] or var[cand] < 0.5 * var[self.ref]:
            self.ref = cand
        ref = self.ref
        biased = full & (np.abs(mean) > self.omega1)
        noisy = full & (var > self.omega2)
        # E[rho] > Omega1 & D[rho] > Omega2 eliminates; back only once both are below
        self.out = (self.out & (biased | noisy)) | (biased & noisy)
        self.out[ref] = False
        reject = self.out.copy()
        excess = np.where(full, np.maximum(var - nominal_var_m2, 0.0), 0.0)
        inflate = np.sqrt(excess + np.where(biased, mean**2, 0.0))
        inflate[ref] = 0.0
        return ~reject, np.where(reject, 0.0, inflate)


def run_aacopf(inputs: LocateInputs, params: LocateParams, seed: int) -> Track:
    """Run the AACOPF over all epochs of ``inputs``; returns its track."""
    rng = np.random.default_rng(seed)
    cloud = init_cloud(inputs, params, rng)
    builder = TrackBuilder("aacopf", inputs, params, rng)
    n_e, n_j = inputs.range_m.shape
    rejected = np.zeros((n_e, n_j), dtype=bool)
    monitor = AuxMonitor(n_j, params)
    # several auxiliaries: one that ranges badly must not remove hypotheses before its
    # residual window has judged it, so until then its likelihood gets an outlier floor
    outlier = params.outlier_sigmas if n_j > 1 and params.warmup == "floor" else 0.0
    j_first = int(np.argmax(np.isfinite(inputs.range_m[0])))
    nominal_var = np.nanmedian(inputs.sigma_m, axis=0) ** 2 + params.likelihood_floor_m**2
    cloud.log_w += log_likelihood(cloud, inputs, 0, params)
    w = normalize_log(cloud.log_w)
    builder.record(0, cloud, w)
    for k in range(n_e - 1):
        propagate(cloud, inputs, k, params, rng)  # step 2
        t = k + 1
        # step 3: residuals of each auxiliary against the predicted range
        w_prior = normalize_log(cloud.log_w)
        for j in range(n_j):
            z = inputs.range_m[t, j]
            if np.isfinite(z):
                ax, ay = inputs.aux_en_m[t, j]
                d_pred = float(w_prior @ np.hypot(cloud.east - ax, cloud.north - ay))
                monitor.add(j, float(z - d_pred))
        use, inflate = monitor.decide(nominal_var)
        if params.warmup == "first":
            # until judged, only the auxiliary of the initial ring is used
            use &= monitor.judged | (np.arange(n_j) == j_first)
        rejected[t] = ~use & np.isfinite(inputs.range_m[t])
        # step 4: weights, eq. (12)-(13)
        cloud.log_w += log_likelihood(
            cloud,
            inputs,
            t,
            params,
            use=use,
            inflate_m=inflate,
            outlier_sigmas=outlier,
            floor_mask=~monitor.judged,
        )
        w = normalize_log(cloud.log_w)
        builder.record(t, cloud, w)  # step 6, eq. (15)-(16)
        if not (use & np.isfinite(inputs.range_m[t])).any():
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
        w_before = w
        cloud.take(idx)
        w = share_weights(w, idx)
        kernel_jitter(cloud, w_before, idx != np.arange(cloud.size), params, rng)
        settled = n_j == 1 or bool(monitor.judged.all())
        if settled and 1.0 / float(w @ w) < params.ess_min * cloud.size:
            # degeneracy guard (once every auxiliary is judged): systematic resampling,
            # weights 1 / (N x M) as step 5 says
            res = systematic_resample(w, float(rng.random()))
            cloud.take(res)
            dup = np.ones(cloud.size, dtype=bool)
            dup[np.unique(res, return_index=True)[1]] = False  # first copies stay exact
            kernel_jitter(cloud, w, dup, params, rng)
            cloud.log_w = np.full(cloud.size, -np.log(cloud.size))
        else:
            with np.errstate(divide="ignore"):
                cloud.log_w = np.log(w)
    return builder.build(rejected=rejected)
