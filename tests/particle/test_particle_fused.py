"""The fused AACOPF kernels (issue 17, speed) against the plain numpy forms they replace,
and the kernels' standard normal generator."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.stages.particle.aco import share_weights
from coopproc.stages.particle.fused import (
    jitter_kernel,
    move_and_jitter,
    posterior_moments,
    range_update,
    resample_and_jitter,
)
from coopproc.stages.particle.kernels import weighted_moments
from coopproc.stages.particle.normal import seed_state, standard_normal
from coopproc.stages.particle.pf import systematic_resample


def _cloud(n: int = 400, seed: int = 1) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    east, north = rng.normal(50, 3, n), rng.normal(-20, 2, n)
    phi = rng.normal(3.0, 0.4, n)  # across the +-pi seam
    scale = rng.normal(0, 0.01, n)
    w = rng.random(n) ** 6
    return east, north, phi, phi + 1.0, scale, w / w.sum()


def test_range_update_is_the_gaussian_likelihood_normalized() -> None:
    east, north, _, _, _, w = _cloud()
    log_w = np.log(w)
    ax, ay, z = np.array([40.0, 70.0]), np.array([-10.0, 0.0]), np.array([12.0, 30.0])
    s2 = np.array([0.04, 0.09])
    want = log_w.copy()
    for j in range(2):
        want += -0.5 * (np.hypot(east - ax[j], north - ay[j]) - z[j]) ** 2 / s2[j]
    # the outlier floor on the second auxiliary only
    floor_want = log_w - 0.5 * (np.hypot(east - ax[0], north - ay[0]) - z[0]) ** 2 / s2[0]
    floor_want += np.logaddexp(
        -0.5 * (np.hypot(east - ax[1], north - ay[1]) - z[1]) ** 2 / s2[1], -0.5
    )
    for floor, expect in ((np.full(2, -np.inf), want), (np.array([-np.inf, -0.5]), floor_want)):
        got_log = log_w.copy()
        got = range_update(got_log, east, north, ax, ay, z, s2, floor)
        np.testing.assert_allclose(got_log, expect, rtol=1e-12, atol=1e-9)
        ref = np.exp(expect - expect.max())
        np.testing.assert_allclose(got, ref / ref.sum(), rtol=1e-9, atol=1e-300)


def test_posterior_moments_equal_the_weighted_moments() -> None:
    east, north, phi, _, scale, w = _cloud()
    got = posterior_moments(east, north, phi, np.cos(phi), np.sin(phi), scale, w, 1e-12)
    want = weighted_moments(east, north, phi, scale, w, np.zeros(1, bool), False, 1e-12)
    for a, b in zip(got, want, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_moves_without_jitter_are_take_and_share_weights() -> None:
    east, north, phi, phi0, scale, w = _cloud()
    rng = np.random.default_rng(2)
    idx = np.where(rng.random(w.size) < 0.4, rng.integers(0, w.size, w.size), np.arange(w.size))
    chol = np.eye(4)
    out = move_and_jitter(
        east, north, phi, phi0, scale, w, idx, seed_state(rng), chol, np.zeros(4), 0.0, 0.0, 1.0
    )
    for got, src in zip(out[:5], (east, north, phi, phi0, scale), strict=True):
        np.testing.assert_array_equal(got, src[idx])
    shared = share_weights(w, idx)
    np.testing.assert_allclose(out[5], shared, rtol=1e-12)
    assert out[6] == pytest.approx(1.0 / float(shared @ shared))


def test_moves_and_resampling_jitter_only_the_copies() -> None:
    east, north, phi, phi0, scale, w = _cloud()
    cov = np.diag([4.0, 1.0, 0.01, 1e-4])
    chol, h, a = jitter_kernel(cov, w.size, 0.4, True)
    assert 0 < h < 1 and a == pytest.approx(np.sqrt(1 - h * h))
    mean = np.array([50.0, -20.0, 3.0, 0.0])
    res = systematic_resample(w, 0.3)
    out = resample_and_jitter(
        east, north, phi, phi0, scale, w, 0.3, seed_state(np.random.default_rng(3)),
        chol, mean, 3.0, h, a,
    )  # fmt: skip
    np.testing.assert_array_equal(out[3], phi0[res])  # the lineage's initial azimuth
    first = np.ones(res.size, dtype=bool)
    first[1:] = res[1:] != res[:-1]
    np.testing.assert_array_equal(out[0][first], east[res][first])  # first copies exact
    assert np.all(out[0][~first] != east[res][~first])  # further copies jittered
    # the jitter: a x source + (1 - a) x mean + h L n, n standard normal
    n0 = (out[0][~first] - a * east[res][~first] - (1 - a) * mean[0]) / (h * chol[0, 0])
    assert abs(n0.mean()) < 0.3 and 0.7 < n0.std() < 1.3
    # the same state gives the same draws (a seed gives the same run)
    again = resample_and_jitter(
        east, north, phi, phi0, scale, w, 0.3, seed_state(np.random.default_rng(3)),
        chol, mean, 3.0, h, a,
    )  # fmt: skip
    np.testing.assert_array_equal(again[0], out[0])


def test_standard_normal_draws_are_normal_and_seeded() -> None:
    state = seed_state(np.random.default_rng(5))
    x = np.array([standard_normal(state) for _ in range(200_000)])
    assert abs(x.mean()) < 0.01 and abs(x.std() - 1.0) < 0.01
    # the tail beyond the ziggurat's r = 3.44 and the wedges have the normal's mass
    for k, p in ((1.0, 0.31731), (2.0, 0.04550), (3.0, 0.0027), (3.6, 0.000318)):
        assert abs(float((np.abs(x) > k).mean()) - p) < 4 * np.sqrt(p / x.size) + 1e-5
    same = seed_state(np.random.default_rng(5))
    assert [standard_normal(same) for _ in range(5)] == x[:5].tolist()
