"""The constant-velocity KF + RTS over LS fixes (coopproc.stages.anchors.uwb_kf)."""

from __future__ import annotations

import dataclasses

import numpy as np

from coopproc.estimation.kalman import kf_predict, kf_update, rts_step
from coopproc.stages.anchors.uwb_kf import V0_SIGMA_MPS, cv_filter, cv_smooth
from coopproc.stages.shared.lsq import LsqFixes, LsqParams


def _fixes(seed: int = 0, n: int = 200, sigma: float = 0.1) -> tuple[LsqFixes, np.ndarray]:
    """A tag on a circle at 0.5 m/s, fixes with correlated 2x2 noise at uneven epochs."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.5, 1.5, n))
    ang = 0.5 * t / 10.0
    truth = np.stack([10 * np.cos(ang), 10 * np.sin(ang)], axis=1)
    cov = np.tile(np.array([[1.0, 0.3], [0.3, 0.5]]) * sigma**2, (n, 1, 1))
    noise = np.einsum("ij,ej->ei", np.linalg.cholesky(cov[0]), rng.normal(size=(n, 2)))
    vel = np.full((n, 2), np.nan)
    fix = LsqFixes(t, truth + noise, cov, vel, np.full((n, 2, 2), np.nan), np.zeros(n))
    return fix, truth


def _dense(fix: LsqFixes, q: float) -> tuple[np.ndarray, np.ndarray]:
    """The same filter and smoother with coopproc.estimation.kalman's numpy formulas."""
    n = len(fix.time_s)
    x = np.concatenate([fix.pos[0], [0.0, 0.0]])
    c = np.zeros((4, 4))
    c[:2, :2] = fix.cov[0]
    c[2:, 2:] = np.eye(2) * V0_SIGMA_MPS**2
    h = np.hstack([np.eye(2), np.zeros((2, 2))])
    xf, cf, xp, cp, fs = [x], [c], [x], [c], [np.eye(4)]
    for k in range(1, n):
        dt = fix.time_s[k] - fix.time_s[k - 1]
        f = np.eye(4)
        f[:2, 2:] = np.eye(2) * dt
        qm = q * np.block(
            [
                [np.eye(2) * dt**3 / 3, np.eye(2) * dt**2 / 2],
                [np.eye(2) * dt**2 / 2, np.eye(2) * dt],
            ]
        )
        x, c = kf_predict(x, c, f, qm)
        xp.append(x)
        cp.append(c)
        fs.append(f)
        x, c = kf_update(x, c, fix.pos[k] - h @ x, h, fix.cov[k])
        xf.append(x)
        cf.append(c)
    xs, cs = [xf[-1]], [cf[-1]]
    for k in range(n - 2, -1, -1):
        x_s, c_s = rts_step(xf[k], cf[k], xp[k + 1], cp[k + 1], xs[0], cs[0], fs[k + 1])
        xs.insert(0, x_s)
        cs.insert(0, c_s)
    return np.array(xf), np.array(xs)


def test_filter_and_smoother_match_the_dense_formulas() -> None:
    fix, _ = _fixes()
    params = LsqParams(kf_robust=False, kf_accel_psd=0.05)
    xf, _, _, _, gamma = cv_filter(fix, params)
    xs, cs = cv_smooth(fix, params)
    ref_f, ref_s = _dense(fix, 0.05)
    np.testing.assert_allclose(xf, ref_f, atol=1e-9)
    np.testing.assert_allclose(xs, ref_s, atol=1e-9)
    assert (gamma == 1.0).all()
    assert np.all(np.einsum("kii->ki", cs) > 0)


def test_smoother_beats_filter_beats_fixes_and_outlier_is_rejected() -> None:
    fix, truth = _fixes(seed=1)
    pos = fix.pos.copy()
    pos[100] += [3.0, 0.0]  # a gross error (NLOS through a wall)
    fix = dataclasses.replace(fix, pos=pos)

    def rmse(x: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((x[:, :2] - truth) ** 2, axis=1))))

    params = LsqParams(kf_accel_psd=0.02)
    xf, _, _, _, gamma = cv_filter(fix, params)
    xs, _ = cv_smooth(fix, params)
    assert rmse(xs) < rmse(xf) < rmse(fix.pos)
    assert gamma[100, 0] < 1e-20 and np.median(gamma[:, :2]) == 1.0
    plain_s, _ = cv_smooth(fix, dataclasses.replace(params, kf_robust=False))
    assert np.hypot(*(xs[100, :2] - truth[100])) < 0.2 < np.hypot(*(plain_s[100, :2] - truth[100]))


def test_velocity_observations_enter_when_asked() -> None:
    fix, _ = _fixes(seed=2)
    n = len(fix.time_s)
    vel = np.tile([5.0, 0.0], (n, 1))  # far from the true 0.5 m/s: must pull the state
    vcov = np.tile(np.eye(2) * 1e-4, (n, 1, 1))
    fix = dataclasses.replace(fix, vel=vel, vel_cov=vcov)
    off, _ = cv_smooth(fix, LsqParams(kf_robust=False))
    on, _ = cv_smooth(fix, LsqParams(kf_robust=False, kf_velocity=True))
    assert abs(np.median(off[:, 2])) < 1.0 and np.median(on[:, 2]) > 4.0
