"""Known-answer tests for eq. (3) increments, eq. (14) ACO, resampling and eq. (17)-(19)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.estimation.angles import heading_deg, wrap_pi
from coopproc.model import Trajectory
from coopproc.stages.particle.aco import aco_targets, share_weights, top_k
from coopproc.stages.particle.increments import dr_increments, rotation_between
from coopproc.stages.particle.observability import analyze, observability_matrix, transition
from coopproc.stages.particle.pf import systematic_resample


def _traj(en: np.ndarray, time_s: np.ndarray | None = None) -> Trajectory:
    t = np.arange(en.shape[0], dtype=float) if time_s is None else time_s
    return Trajectory("T", t, np.column_stack([en, np.zeros(en.shape[0])]))


def test_increments_of_a_square_path() -> None:
    # 2 m east, 2 m north, 2 m west (one epoch per metre), a still epoch at the end
    en = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [1, 2], [0, 2], [0, 2]], float)
    inc = dr_increments(_traj(en), np.arange(8.0))
    np.testing.assert_allclose(inc.delta_l_m, [1, 1, 1, 1, 1, 1, 0])
    np.testing.assert_allclose(np.degrees(inc.delta_phi_rad), [0, 0, 90, 0, 90, 0, 0])
    assert inc.theta0_rad == pytest.approx(0.0)
    # eq. (3) with phi(0) = theta0 rebuilds the path
    phi = inc.theta0_rad + np.cumsum(inc.delta_phi_rad)
    steps = inc.delta_l_m[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    np.testing.assert_allclose(np.cumsum(steps, axis=0), en[1:], atol=1e-12)


def test_increments_ignore_the_unknown_frame() -> None:
    rng = np.random.default_rng(4)
    en = np.cumsum(rng.normal(0, 1, (50, 2)), axis=0)
    a = np.radians(73.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    moved = en @ rot.T + np.array([1000.0, -250.0])
    t = np.arange(50.0)
    one, two = dr_increments(_traj(en), t), dr_increments(_traj(moved), t)
    np.testing.assert_allclose(one.delta_l_m, two.delta_l_m, atol=1e-9)
    np.testing.assert_allclose(one.delta_phi_rad, two.delta_phi_rad, atol=1e-9)
    assert wrap_pi(two.theta0_rad - one.theta0_rad) == pytest.approx(a)
    psi = rotation_between(one.step_own_m, two.step_own_m, 1e9)
    assert psi == pytest.approx(a)


def test_leading_still_steps_take_the_first_direction() -> None:
    en = np.array([[0, 0], [0, 0], [0, 1], [0, 2]], float)
    inc = dr_increments(_traj(en), np.arange(4.0))
    np.testing.assert_allclose(np.degrees(inc.theta_rad), [90, 90, 90])
    assert heading_deg(inc.theta0_rad) == pytest.approx(0.0)
    assert heading_deg(0.0) == pytest.approx(90.0)
    assert heading_deg(-np.pi / 2) == pytest.approx(180.0)


def _aco_brute(east, north, w, alpha, beta, lam, gate):
    """Eq. (14) over every particle (the O(P^2) rule) for small clouds."""
    w1 = w / w.max()
    out = np.arange(w.shape[0])
    for i in range(w.shape[0]):
        if w1[i] >= gate:
            continue
        dw = w1 - w1[i]
        dist = np.maximum(np.hypot(east - east[i], north - north[i]), 1e-3)
        v = np.where(dw > 0, np.abs(dw) ** alpha * dist ** (-beta), 0.0)
        if v.sum() > 0 and v.max() / v.sum() > lam:
            out[i] = int(np.argmax(v))
    return out


@pytest.mark.parametrize(("alpha", "beta", "lam"), [(1.0, 1.0, 0.0), (2.0, 0.5, 0.3)])
def test_aco_with_every_candidate_is_eq14(alpha: float, beta: float, lam: float) -> None:
    rng = np.random.default_rng(1)
    east, north = rng.uniform(0, 5, 40), rng.uniform(0, 5, 40)
    w = rng.random(40) ** 4
    w /= w.sum()
    got = aco_targets(east, north, w, 40, alpha, beta, lam, 0.5, gate=0.5)
    np.testing.assert_array_equal(got, _aco_brute(east, north, w, alpha, beta, lam, 0.5))


def _aco_local_brute(east, north, w, k, lam, cell_m, gate):
    """Eq. (14) (alpha = beta = 1) over the candidate set aco.py documents: the k
    heaviest particles and the heaviest particle of each cell of i's 3 x 3 neighbourhood."""
    w1 = w / w.max()
    cand = set(top_k(w1, k).tolist())
    cx = np.floor((east - east.min()) / cell_m).astype(int)
    cy = np.floor((north - north.min()) / cell_m).astype(int)
    champ: dict[tuple[int, int], int] = {}
    for j in range(w.shape[0]):
        key = (int(cx[j]), int(cy[j]))
        if key not in champ or w1[j] > w1[champ[key]]:
            champ[key] = j
    out = np.arange(w.shape[0])
    for i in range(w.shape[0]):
        if w1[i] >= gate:
            continue
        near = {champ.get((cx[i] + dx, cy[i] + dy), -1) for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
        js = np.array(sorted((cand | near) - {-1}))
        dist = np.maximum(np.hypot(east[js] - east[i], north[js] - north[i]), 1e-3)
        v = np.maximum(w1[js] - w1[i], 0.0) / dist
        if v.sum() > 0 and v.max() / v.sum() > lam:
            out[i] = int(js[np.argmax(v)])
    return out


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_aco_local_candidates_follow_the_documented_set(seed: int) -> None:
    # a cloud much wider than the cells: most candidates are the local cell champions
    rng = np.random.default_rng(seed)
    east, north = rng.uniform(0, 6, 300), rng.uniform(0, 4, 300)
    w = rng.random(300) ** 8
    w /= w.sum()
    got = aco_targets(east, north, w, 3, 1.0, 1.0, 0.2, 0.5, gate=0.2)
    want = _aco_local_brute(east, north, w, 3, 0.2, 0.5, 0.2)
    np.testing.assert_array_equal(got, want)
    assert (got != np.arange(300)).sum() > 100  # the rule moved most light particles


def test_aco_hand_case_and_weight_sharing() -> None:
    # particle 2 is light; 0 (w 1) is 10 m away, 1 (w 0.5) is 1 m away:
    # v_0 = (1 - 0)/10 = 0.1, v_1 = (0.5 - 0)/1 = 0.5 -> P_21 = 0.5/0.6 > lambda -> moves to 1
    east = np.array([0.0, 9.0, 10.0])
    north = np.zeros(3)
    w = np.array([1.0, 0.5, 0.0])
    idx = aco_targets(east, north, w / w.sum(), 2, 1.0, 1.0, 0.5, 0.2, gate=0.25)
    np.testing.assert_array_equal(idx, [0, 1, 1])
    shared = share_weights(w / w.sum(), idx)
    # 1 and its follower split 1's weight: 1 : 0.25 : 0.25
    np.testing.assert_allclose(shared, [1 / 1.5, 0.25 / 1.5, 0.25 / 1.5])
    # lambda above the best probability: it stays
    idx = aco_targets(east, north, w / w.sum(), 2, 1.0, 1.0, 0.9, 0.2, gate=0.25)
    np.testing.assert_array_equal(idx, [0, 1, 2])


def test_top_k_and_systematic_resampling() -> None:
    w = np.array([0.1, 0.4, 0.1, 0.4])
    np.testing.assert_array_equal(top_k(w, 3), [1, 3, 0])
    idx = systematic_resample(np.array([0.5, 0.25, 0.25]), 0.4)
    np.testing.assert_array_equal(idx, [0, 0, 2])  # positions 0.4/3, 1.4/3, 2.4/3
    counts = np.bincount(systematic_resample(np.array([0.5, 0.25, 0.25, 0.0]), 0.1), minlength=4)
    np.testing.assert_array_equal(counts, [2, 1, 1, 0])


def _line(n: int = 60) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Paper 004 fig. 5: the target moves on a line of slope 0.5 at 1 m per epoch."""
    phi = np.arctan(0.5)
    step = np.array([np.cos(phi), np.sin(phi)])
    target = np.arange(n)[:, None] * step
    return target, np.ones(n - 1), np.full(n - 1, phi)


def test_observability_matrix_is_eq18() -> None:
    target, dl, phi = _line(6)
    aux = np.column_stack([np.linspace(5, 9, 6), np.linspace(-3, 4, 6)])[:, None, :]
    rows, ep = observability_matrix(target, aux, np.ones((6, 1), bool), dl, phi)
    expected = []
    prod = np.eye(3)
    for t in range(6):
        rel = target[t] - aux[t, 0]
        h = np.array([rel[0], rel[1], 0.0]) / np.hypot(*rel)
        expected.append(h @ prod)
        if t < 5:
            prod = transition(dl[t], phi[t]) @ prod
    np.testing.assert_allclose(rows, np.array(expected), atol=1e-12)
    np.testing.assert_array_equal(ep, np.arange(6))


def test_table1_pattern() -> None:
    """Paper 004 Table 1: a zero singular value with a fixed auxiliary and with motion in
    the same relative direction, full rank with relative motion."""
    target, dl, phi = _line()
    n = target.shape[0]
    has = np.ones((n, 1), bool)
    fixed = np.tile([[20.0, 0.0]], (n, 1))[:, None, :]
    same = (target + np.array([12.0, -7.0]))[:, None, :]
    t = np.arange(n)
    relative = np.column_stack([30 - 0.8 * t, 5 + 10 * np.sin(t / 8)])[:, None, :]
    sv = {
        name: analyze(target, aux, has, dl, phi, 1e-3)
        for name, aux in (("fixed", fixed), ("same", same), ("relative", relative))
    }
    assert sv["fixed"].singular_values[2] < 1e-9 * sv["fixed"].singular_values[0]
    assert sv["same"].singular_values[2] < 1e-9 * sv["same"].singular_values[0]
    assert sv["relative"].singular_values[2] > 1e-2 * sv["relative"].singular_values[0]
    assert not sv["fixed"].observable and not sv["same"].observable
    assert sv["relative"].observable and sv["relative"].observable_from is not None
    assert sv["fixed"].observable_from is None
