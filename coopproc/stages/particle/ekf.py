"""The EKF baseline of paper 004: state [x, y, phi], eq. (3) motion, range updates.

One EKF started from a coarse guess (the target at ``ekf_initial_bearing_deg`` from the
first auxiliary at the first measured range, heading ``ekf_initial_azimuth_deg``) with a
covariance as wide as the ring, as the paper's comparison does, cannot converge: the
ring of hypotheses the particle filters start from is far from Gaussian. With
``ekf_bearings`` x ``ekf_azimuths`` > 1 it is a bank of EKFs (a Gaussian-sum filter,
Alspach & Sorenson 1972): one EKF per initial bearing on the ring and initial azimuth,
evenly spread from the coarse guess, each with a covariance the size of its share of
the ring; every one accumulates the log-likelihood of its range innovations, and the
reported state at each epoch is the one of the most likely EKF so far (causal).
All EKFs run vectorized (arrays over the hypotheses).
"""

from __future__ import annotations

import numpy as np

from coopproc.estimation.angles import wrap_pi
from coopproc.estimation.locate_result import LocateInputs, Track
from coopproc.estimation.range_model import slant_ranges_units
from coopproc.model import FloatArray
from coopproc.stages.particle.modes import modes_of_hypotheses
from coopproc.stages.particle.params import LocateParams
from coopproc.stages.particle.progress import ProgressFn

__all__ = ["initial_hypotheses", "run_ekf"]


def initial_hypotheses(inputs: LocateInputs, params: LocateParams) -> tuple[FloatArray, FloatArray]:
    """Initial states (H, 3) [east, north, phi] and covariances (H, 3, 3) of the EKF bank."""
    center, d1 = inputs.first_fix()
    nb, na = params.ekf_bearings, params.ekf_azimuths
    # bearings clockwise from north, azimuths as headings; the coarse guess comes first
    bearing = np.radians(params.ekf_initial_bearing_deg) + 2.0 * np.pi * np.arange(nb) / nb
    heading = np.radians(params.ekf_initial_azimuth_deg) + 2.0 * np.pi * np.arange(na) / na
    b, h = np.repeat(bearing, na), np.tile(heading, nb)
    x = np.column_stack([center[0] + d1 * np.sin(b), center[1] + d1 * np.cos(b), np.pi / 2 - h])
    # one EKF: as wide as the ring; a bank: one sector of the ring and of the azimuths each
    pos_sd = max(d1, 1.0) if nb == 1 else max(np.pi * d1 / nb, params.delta_d_m, 0.5)
    phi_sd = np.pi / 2 if na == 1 else np.pi / na
    p0 = np.diag([pos_sd**2, pos_sd**2, phi_sd**2])
    return x, np.repeat(p0[None], x.shape[0], axis=0)


def run_ekf(
    inputs: LocateInputs, params: LocateParams, progress: ProgressFn | None = None
) -> Track:
    """Run the EKF (bank) over all epochs of ``inputs``; returns its track."""
    n_e, n_j = inputs.range_m.shape
    x, p = initial_hypotheses(inputs, params)
    n_h = x.shape[0]
    loglik = np.zeros(n_h)
    inc = inputs.increments
    turned = inc.heading_own_rad() - inc.theta0_rad
    out = np.empty((n_e, 3))
    eye = np.eye(3)
    for t in range(n_e):
        if t > 0:
            dl = float(inc.delta_l_m[t - 1])
            x[:, 2] += float(inc.delta_phi_rad[t - 1])  # eq. (3)
            c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
            x[:, 0] += dl * c
            x[:, 1] += dl * s
            # eq. (17) transition Phi, linearized at the propagated azimuth
            phi_mat = np.repeat(eye[None], n_h, axis=0)
            phi_mat[:, 0, 2] = -dl * s
            phi_mat[:, 1, 2] = dl * c
            dt = max(float(inputs.time_s[t] - inputs.time_s[t - 1]), 0.0)
            sxy = params.step_sigma_m * np.sqrt(dt) + params.step_sigma_rel * dl
            # the odometer scale error (see core.propagate) as extra along-track noise
            along = params.odometer_scale_sigma * dl
            q = np.diag([sxy**2 + along**2, sxy**2 + along**2, 0.0])
            q[2, 2] = np.radians(params.heading_sigma_deg) ** 2 * dt
            p = phi_mat @ p @ phi_mat.transpose(0, 2, 1) + q
        for j in range(n_j):
            z = inputs.range_m[t, j]
            if not np.isfinite(z):
                continue
            ax, ay = inputs.aux_en_m[t, j]
            d, unit = slant_ranges_units(np.column_stack([x[:, 0] - ax, x[:, 1] - ay]))
            h = np.column_stack([unit, np.zeros(n_h)])  # eq. (17) H, (H, 3)
            r = inputs.sigma_m[t, j] ** 2 + params.likelihood_floor_m**2
            ph = np.einsum("hij,hj->hi", p, h)
            s_inn = np.einsum("hi,hi->h", h, ph) + r
            gain = ph / s_inn[:, None]
            inn = z - d
            loglik += -0.5 * (inn**2 / s_inn + np.log(2.0 * np.pi * s_inn))
            x = x + gain * inn[:, None]
            ikh = eye[None] - gain[:, :, None] * h[:, None, :]
            p = ikh @ p @ ikh.transpose(0, 2, 1) + r * gain[:, :, None] * gain[:, None, :]
        out[t] = x[int(np.argmax(loglik))]  # Joseph form above; the most likely EKF here
        if progress is not None:
            progress("ekf", t + 1, n_e)
    phi = wrap_pi(out[:, 2])
    init_track = wrap_pi(out[:, 2] - turned)
    # the bank's modes: its EKFs weighted by their likelihoods, clustered like particles
    final = modes_of_hypotheses(
        x[:, 0], x[:, 1], x[:, 2], loglik, params.mode_cell_m, params.mode_az_deg
    )
    return Track(
        method="ekf",
        time_s=inputs.time_s,
        east_m=out[:, 0].copy(),
        north_m=out[:, 1].copy(),
        phi_rad=phi,
        initial_azimuth_track_rad=init_track,
        initial_azimuth_rad=float(init_track[-1]),
        modes=final.modes,
    )
