"""The constant-velocity process model and the compiled RTS smoother of the estimation
layer (issue 34 part 1), against their definitions."""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad_vec

from coopproc.estimation.kalman import kf_predict, kf_update, rts_backward_nb, rts_step
from coopproc.estimation.process_models import cv_transition


def test_the_cv_noise_is_the_integrated_white_acceleration() -> None:
    """Q = int_0^dt F(s) G q G^T F(s)^T ds with G = [0; I]: the continuous model."""
    dt, psd = 0.7, np.array([0.3, 2.0, 0.05])
    f, q = cv_transition(dt, psd)
    d = psd.shape[0]
    g = np.vstack([np.zeros((d, d)), np.eye(d)])

    def integrand(s: float) -> np.ndarray:
        fs = cv_transition(s, psd)[0]
        return fs @ g @ np.diag(psd) @ g.T @ fs.T

    np.testing.assert_allclose(q, quad_vec(integrand, 0.0, dt)[0], rtol=1e-10, atol=1e-14)
    x = np.array([1.0, 2.0, 3.0, 0.5, -1.0, 0.1])
    np.testing.assert_allclose(f @ x, [1.35, 1.3, 3.07, 0.5, -1.0, 0.1])


def test_the_compiled_rts_is_the_reference_step() -> None:
    rng = np.random.default_rng(5)
    k_n, d = 30, 2
    t = np.cumsum(rng.uniform(0.1, 0.5, k_n))
    x, c = np.zeros(2 * d), np.eye(2 * d)
    xf, cf, xp, cp, fs = (np.zeros((k_n, 2 * d)), np.zeros((k_n, 2 * d, 2 * d)),
                          np.zeros((k_n, 2 * d)), np.zeros((k_n, 2 * d, 2 * d)),
                          np.zeros((k_n, 2 * d, 2 * d)))  # fmt: skip
    h = np.hstack([np.eye(d), np.zeros((d, d))])
    for k in range(k_n):
        if k:
            fs[k], q = cv_transition(t[k] - t[k - 1], np.full(d, 0.5))
            x, c = kf_predict(x, c, fs[k], q)
        xp[k], cp[k] = x, c
        x, c = kf_update(x, c, rng.normal(0.0, 1.0, d) - h @ x, h, np.full(d, 0.2))
        xf[k], cf[k] = x, c
    xs, cs = rts_backward_nb(xf, cf, xp, cp, fs)
    ref_x, ref_c = xf[-1], cf[-1]
    for k in range(k_n - 2, -1, -1):
        ref_x, ref_c = rts_step(xf[k], cf[k], xp[k + 1], cp[k + 1], ref_x, ref_c, fs[k + 1])
        np.testing.assert_allclose(xs[k], ref_x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(cs[k], ref_c, rtol=1e-9, atol=1e-12)
    assert np.all(np.diagonal(cs, axis1=1, axis2=2) <= np.diagonal(cf, axis1=1, axis2=2) + 1e-12)
