"""The EKF baseline of paper 004: state [x, y, phi], eq. (3) motion, range updates.

Started from a coarse guess (the target at ``ekf_initial_bearing_deg`` from the first
auxiliary at the first measured range, heading ``ekf_initial_azimuth_deg``) with a wide
covariance, as the paper's comparison does: the EKF has no way to hold the ring of
hypotheses the particle filters start from.
"""

from __future__ import annotations

import numpy as np

from coopproc.stages.particle.core import Track
from coopproc.stages.particle.increments import wrap_pi
from coopproc.stages.particle.inputs import LocateInputs
from coopproc.stages.particle.params import LocateParams

__all__ = ["run_ekf"]


def run_ekf(inputs: LocateInputs, params: LocateParams) -> Track:
    """Run the EKF over all epochs of ``inputs``; returns its track."""
    n_e, n_j = inputs.range_m.shape
    center, d1 = inputs.first_fix()
    bearing = np.radians(params.ekf_initial_bearing_deg)  # clockwise from north
    x = np.array(
        [
            center[0] + d1 * np.sin(bearing),
            center[1] + d1 * np.cos(bearing),
            np.radians(90.0 - params.ekf_initial_azimuth_deg),
        ]
    )
    p = np.diag([max(d1, 1.0) ** 2, max(d1, 1.0) ** 2, (np.pi / 2) ** 2])
    inc = inputs.increments
    turned = inc.heading_own_rad() - inc.theta0_rad
    out = np.empty((n_e, 3))
    eye = np.eye(3)
    for t in range(n_e):
        if t > 0:
            dl = float(inc.delta_l_m[t - 1])
            x[2] += float(inc.delta_phi_rad[t - 1])  # eq. (3)
            c, s = np.cos(x[2]), np.sin(x[2])
            x[0] += dl * c
            x[1] += dl * s
            # eq. (17) transition Phi, linearized at the propagated azimuth
            phi_mat = np.array([[1.0, 0.0, -dl * s], [0.0, 1.0, dl * c], [0.0, 0.0, 1.0]])
            dt = max(float(inputs.time_s[t] - inputs.time_s[t - 1]), 0.0)
            sxy = params.step_sigma_m * np.sqrt(dt) + params.step_sigma_rel * dl
            q = np.diag([sxy**2, sxy**2, np.radians(params.heading_sigma_deg) ** 2 * dt])
            p = phi_mat @ p @ phi_mat.T + q
        for j in range(n_j):
            z = inputs.range_m[t, j]
            if not np.isfinite(z):
                continue
            ax, ay = inputs.aux_en_m[t, j]
            dx, dy = x[0] - ax, x[1] - ay
            d = max(float(np.hypot(dx, dy)), 1e-6)
            h = np.array([[dx / d, dy / d, 0.0]])  # eq. (17) H
            r = inputs.sigma_m[t, j] ** 2 + params.likelihood_floor_m**2
            s_inn = float((h @ p @ h.T)[0, 0]) + r
            gain = (p @ h.T) / s_inn
            x = x + gain[:, 0] * (z - d)
            ikh = eye - gain @ h
            p = ikh @ p @ ikh.T + r * (gain @ gain.T)  # Joseph form
        out[t] = x
    phi = wrap_pi(out[:, 2])
    init_track = wrap_pi(out[:, 2] - turned)
    return Track(
        method="ekf",
        time_s=inputs.time_s,
        east_m=out[:, 0].copy(),
        north_m=out[:, 1].copy(),
        phi_rad=phi,
        initial_azimuth_track_rad=init_track,
        initial_azimuth_rad=float(init_track[-1]),
    )
