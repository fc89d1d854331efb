"""The memory-bounded MBF smoother against the dense RTS recursion (paper 003 sec. 2.8)."""

from __future__ import annotations

import numpy as np
import pytest

from coopproc.estimation.kalman import rts_step
from coopproc.stages.fusion.ekf import OBS_ANCHOR, OBS_POSITION, OBS_RANGE, ekf_forward, nav_at
from coopproc.stages.fusion.kernel_types import (
    Navigation,
    Observations,
    Process,
    Reads,
    Robust,
    Slots,
)
from coopproc.stages.fusion.smoother import mbf_backward

DIM = 2
ROBUST = Robust(True, 3.0, 4.0, 1.0, 20)


def _problem(seed: int, n_plat: int = 3, n_ep: int = 60) -> dict[str, np.ndarray]:
    """Platforms wandering in 2D with noisy DR, ranges between them and to an anchor,
    platform 0's own fix every 3rd epoch, one gross outlier; the last epoch observes
    nothing (so that its checkpoint gives the previous epoch's posterior covariance)."""
    rng = np.random.default_rng(seed)
    truth = np.cumsum(rng.normal(0, 0.3, (n_plat, n_ep, 3)), axis=1)
    truth[:, :, 0] += 10.0 * np.arange(n_plat)[:, None]
    nav = truth + np.cumsum(rng.normal(0, 0.05, (n_plat, n_ep, 3)), axis=1)
    anchor_pos = np.array([5.0, 20.0, 0.0])
    kinds, a_list, b_list, anchors, z, var, counts = [], [], [], [], [], [], []
    for k in range(n_ep - 1):
        m = 0
        if k % 3 == 0:
            for axis in range(DIM):
                kinds.append(OBS_POSITION)
                a_list.append(0)
                b_list.append(axis)
                anchors.append(np.zeros(3))
                z.append(truth[0, k, axis] + rng.normal(0, 0.05))
                var.append(0.05**2)
                m += 1
        a, b = rng.choice(n_plat, 2, replace=False)
        kinds.append(OBS_RANGE)
        a_list.append(a)
        b_list.append(b)
        anchors.append(np.zeros(3))
        z.append(np.linalg.norm(truth[a, k, :DIM] - truth[b, k, :DIM]) + rng.normal(0, 0.1))
        var.append(0.1**2)
        m += 1
        p = rng.integers(n_plat)
        kinds.append(OBS_ANCHOR)
        a_list.append(p)
        b_list.append(-1)
        anchors.append(anchor_pos)
        z.append(np.linalg.norm(truth[p, k, :DIM] - anchor_pos[:DIM]) + rng.normal(0, 0.1))
        var.append(0.1**2)
        m += 1
        counts.append(m)
    counts.append(0)
    z_arr = np.array(z)
    z_arr[len(z) // 2] += 5.0  # a gross error the IGG-III factor must reject
    n_obs = len(z)
    return {
        "x0": nav[:, 0, :DIM].reshape(-1).copy(),
        "c0": np.eye(n_plat * DIM) * 0.5,
        "nav": np.ascontiguousarray(nav),
        # the kernels' navigation: each platform's samples (here at the epochs themselves)
        "epochs": np.arange(n_ep) * 0.5,
        "nav_t": np.tile(np.arange(n_ep) * 0.5, n_plat),
        "nav_v": np.ascontiguousarray(nav[:, :, :DIM].reshape(-1, DIM)),
        "nav_ptr": np.arange(n_plat + 1, dtype=np.int64) * n_ep,
        "q_coef": np.full(n_plat, 0.02),
        "dt": np.full(n_ep, 0.5),
        "ptr": np.concatenate(([0], np.cumsum(counts))).astype(np.int64),
        "kind": np.array(kinds, dtype=np.int8),  # the dtypes fuse() passes
        "a": np.array(a_list, dtype=np.int32),
        "b": np.array(b_list, dtype=np.int32),
        "anchor": np.arange(len(anchors), dtype=np.int32),  # rows of anchor_table
        "anchor_table": np.array(anchors),
        "dz2": np.zeros(n_obs),
        "z": z_arr,
        "var": np.array(var),
    }


def _forward(pb: dict[str, np.ndarray], rec: Slots, block: int):
    return ekf_forward(
        pb["x0"], pb["c0"], *_kernel(pb), DIM, ROBUST, rec, block, np.zeros(0, np.int64),
        np.zeros(0), Reads(rec.ptr, rec.plat, np.zeros(0, np.int64)),
    )  # fmt: skip


def _kernel(pb: dict[str, np.ndarray]) -> tuple[Navigation, Process, Observations]:
    """The problem as the kernels take it (DR states where ``pb`` has them)."""
    nav = Navigation(pb["epochs"], pb["nav_t"], pb["nav_v"], pb["nav_ptr"])
    proc = Process.without_dr(pb["q_coef"], False, pb["dt"])
    if "dr_idx" in pb:
        proc = proc._replace(dr_idx=pb["dr_idx"], dr_q=pb["dr_q"])
    obs = Observations(
        pb["ptr"], pb["kind"], pb["a"], pb["b"], pb["anchor"], pb["anchor_table"], pb["dz2"],
        pb["z"], pb["var"],
    )  # fmt: skip
    return nav, proc, obs


def _all_slots(n_ep: int, n_plat: int) -> Slots:
    ptr = np.arange(n_ep + 1, dtype=np.int64) * n_plat
    return Slots(ptr, np.tile(np.arange(n_plat, dtype=np.int64), n_ep))


def _dense_rts(pb: dict[str, np.ndarray], n_plat: int) -> tuple[np.ndarray, np.ndarray]:
    """States and variances of the dense RTS recursion (filters.rts_step) at every epoch
    but the last, from the forward pass's posteriors (checkpoints with block = 1)."""
    n_ep = pb["dt"].shape[0]
    xs_f, _, _, _, _, _, cp_c, *_ = _forward(pb, _all_slots(n_ep, n_plat), 1)
    xs_f = xs_f.reshape(n_ep, n_plat * DIM)
    post = cp_c[1:]  # posterior covariance of epochs 0 .. K - 2
    q = (pb["q_coef"] * pb["dt"][:, None]).repeat(DIM, axis=1)
    u = np.zeros_like(xs_f)
    u[1:] = np.diff(pb["nav"][:, :, :DIM], axis=1).transpose(1, 0, 2).reshape(n_ep - 1, -1)
    last = n_ep - 2
    xs = [xs_f[last]]
    cs = [post[last]]
    for k in range(last - 1, -1, -1):
        c_pred = post[k] + np.diag(q[k + 1])
        x_s, c_s = rts_step(
            xs_f[k], post[k], xs_f[k] + u[k + 1], c_pred, xs[-1], cs[-1], np.eye(xs_f.shape[1])
        )
        xs.append(x_s)
        cs.append(c_s)
    return np.array(xs[::-1]), np.array([np.diag(c) for c in cs[::-1]])


@pytest.mark.parametrize(("seed", "block"), [(0, 7), (1, 16), (2, 1), (3, 200)])
def test_mbf_smoother_equals_dense_rts(seed: int, block: int) -> None:
    n_plat = 3
    pb = _problem(seed, n_plat)
    n_ep = pb["dt"].shape[0]
    rec = _all_slots(n_ep, n_plat)
    _, _, gamma, _, _, cp_x, cp_c, *_ = _forward(pb, rec, block)
    assert (gamma < 1e-6).sum() >= 1  # the outlier was rejected, and the smoother knows it
    xs, var, *_ = mbf_backward(cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, block)
    ref_x, ref_var = _dense_rts(pb, n_plat)
    got_x = xs.reshape(n_ep, -1)[:-1]
    got_var = var.reshape(n_ep, -1)[:-1]
    assert got_x == pytest.approx(ref_x, abs=1e-9)
    assert got_var == pytest.approx(ref_var, rel=1e-8, abs=1e-12)
    # smoothing used the future: the variances are below the filtered ones
    _, var_f, *_ = _forward(pb, rec, block)
    assert (got_var <= var_f.reshape(n_ep, -1)[:-1] + 1e-12).all()
    assert np.abs(got_var - var_f.reshape(n_ep, -1)[:-1]).max() > 1e-3


def test_recorded_subset_gives_the_same_slots() -> None:
    n_plat = 3
    pb = _problem(5, n_plat)
    n_ep = pb["dt"].shape[0]
    full = _all_slots(n_ep, n_plat)
    rng = np.random.default_rng(9)
    keep = rng.random(full[1].shape[0]) < 0.3
    epoch_of = np.repeat(np.arange(n_ep), n_plat)
    sub_ptr = np.concatenate(([0], np.cumsum(np.bincount(epoch_of[keep], minlength=n_ep))))
    sub = Slots(sub_ptr.astype(np.int64), full[1][keep])
    outs = []
    for rec in (full, sub):
        xs_f, var_f, gamma, _, _, cp_x, cp_c, *_ = _forward(pb, rec, 8)
        xs, var, *_ = mbf_backward(cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, 8)
        outs.append((xs_f, var_f, xs, var))
    for whole, part in zip(outs[0], outs[1], strict=True):
        np.testing.assert_array_equal(whole[keep], part)


def test_nav_at_is_np_interp_bit_for_bit() -> None:
    """The kernels' navigation at a time is np.interp's value, bit for bit, for times
    between, on and beyond the samples, going forward and (a smoother block) back."""
    rng = np.random.default_rng(4)
    sizes = (7, 1, 40)
    times = [np.sort(rng.uniform(0, 10, n)) for n in sizes]
    times[2][5] = times[2][6]  # a repeated sample time
    values = [rng.normal(0, 100, (n, 2)) for n in sizes]
    values[0][3, 1] = np.inf  # numpy's NaN fallback
    nav_t = np.concatenate(times)
    nav_v = np.concatenate(values)
    ptr = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    query = np.concatenate((np.sort(rng.uniform(-1, 11, 300)), times[0], times[2]))
    query = np.concatenate((np.sort(query), rng.uniform(-1, 11, 50)))  # then jumping about
    cursor = np.full(len(sizes), -1, dtype=np.int64)
    out = np.zeros((len(sizes), 2))
    for x in query:
        nav_at(nav_t, nav_v, ptr, x, cursor, out)
        for p in range(len(sizes)):
            want = [np.interp(x, times[p], values[p][:, ax]) for ax in range(2)]
            np.testing.assert_array_equal(out[p], want)


@pytest.mark.parametrize("with_var", [True, False])
def test_pipelined_smoother_is_the_sequential_one_bit_for_bit(with_var: bool) -> None:
    """Re-runs in two or three worker threads beside the backward pass change no bit of
    the result."""
    n_plat = 3
    pb = _problem(6, n_plat)
    n_ep = pb["dt"].shape[0]
    rec = _all_slots(n_ep, n_plat)
    _, _, gamma, _, _, cp_x, cp_c, *_ = _forward(pb, rec, 5)
    # blocks enough for every buffer to be reused by a later block's re-run
    assert cp_x.shape[0] >= 8
    results = []
    for threads in (1, 2, 3):
        smoothed = mbf_backward(
            cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, 5, with_var, threads=threads
        )
        results.append(smoothed)
    for other in results[1:]:
        for one, two in zip(results[0], other, strict=True):
            assert one.tobytes() == two.tobytes()
    assert np.isfinite(results[0][0]).all() and results[0][0].shape == (rec[1].shape[0], DIM)


def test_a_pass_without_variances_gives_the_states_of_one_with_them() -> None:
    """Without variances the backward pass carries lambda alone (no Lambda): the smoothed
    states are those of the pass that forms the variances, bit for bit, and differ from
    the filtered ones (the smoother did something)."""
    n_plat = 3
    pb = _problem(6, n_plat)
    rec = _all_slots(pb["dt"].shape[0], n_plat)
    xs_f, _, gamma, _, _, cp_x, cp_c, *_ = _forward(pb, rec, 5)
    full = mbf_backward(cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, 5, True, threads=1)
    states = mbf_backward(cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, 5, False, threads=1)
    assert states.var.shape == (0, DIM) and full.var.shape == full.xs.shape
    assert states.xs.tobytes() == full.xs.tobytes()
    assert np.abs(states.xs - xs_f).max() > 1e-3
    # with DR states: the followers' transitions step lambda alone too (adjoint_touch_vector)
    pb = _with_dr(pb, (0, 2))
    dr_rec = np.arange(pb["dt"].shape[0], dtype=np.int64)
    reads = Reads(rec.ptr, rec.plat, dr_rec)
    _, _, gamma, _, _, cp_x, cp_c, *_ = ekf_forward(
        pb["x0"], pb["c0"], *_kernel(pb), DIM, ROBUST, rec, 5, dr_rec, np.zeros(0), reads
    )
    kernel = (cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, 5, False)
    with_dr = mbf_backward(*kernel, threads=1, dr_rec=dr_rec, reads=reads)
    alone = mbf_backward(*kernel, threads=2, dr_rec=dr_rec[:0], reads=reads)
    assert with_dr.dr_var.shape[0] == dr_rec.shape[0] and alone.dr_var.shape[0] == 0
    assert alone.xs.tobytes() == with_dr.xs.tobytes()


def _with_dr(pb: dict[str, np.ndarray], dr_plats: tuple[int, ...]) -> dict[str, np.ndarray]:
    """The problem with heading/heading-rate/scale states for ``dr_plats`` (after the
    positions), their priors wide enough for the linearization to matter."""
    n_plat = pb["nav_ptr"].shape[0] - 1
    n_pos = n_plat * DIM
    idx = np.full(n_plat, -1, dtype=np.int64)
    for j, p in enumerate(dr_plats):
        idx[p] = n_pos + 3 * j
    n = n_pos + 3 * len(dr_plats)
    x0 = np.zeros(n)
    x0[:n_pos] = pb["x0"]
    x0[n_pos:] = np.tile([0.05, 0.002, 0.01], len(dr_plats))  # a linearization off zero
    c0 = np.zeros((n, n))
    c0[:n_pos, :n_pos] = pb["c0"]
    c0[n_pos:, n_pos:] = np.diag(np.tile([0.05**2, 0.002**2, 0.02**2], len(dr_plats)))
    q = np.zeros((n_plat, 5))
    q[list(dr_plats)] = [1e-4, 1e-7, 1e-6, 1e-3, 1e-4]  # per second; per metre
    return dict(pb, x0=x0, c0=c0, dr_idx=idx, dr_q=q)


def _dr_transition(
    pb: dict[str, np.ndarray], x_post: np.ndarray, k: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model of coopproc.estimation.dr_model written densely: x_k = f(x_{k-1}),
    its Jacobian F (by central finite differences of f) and Q_k."""
    n_plat = pb["nav_ptr"].shape[0] - 1
    u = pb["nav"][:, k, :DIM] - pb["nav"][:, k - 1, :DIM]
    dt = pb["dt"][k]

    def f(x: np.ndarray) -> np.ndarray:
        out = x.copy()
        for p in range(n_plat):
            e = pb["dr_idx"][p]
            if e < 0:
                out[p * DIM : p * DIM + DIM] += u[p]
                continue
            th, om, s = x[e], x[e + 1], x[e + 2]
            rot = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
            out[p * DIM : p * DIM + DIM] += (1 + s) * rot @ u[p]
            out[e] = th + om * dt
        return out

    n = x_post.shape[0]
    jac = np.zeros((n, n))
    for j in range(n):
        step = np.zeros(n)
        step[j] = 1e-6
        jac[:, j] = (f(x_post + step) - f(x_post - step)) / 2e-6
    q = np.zeros(n)
    for p in range(n_plat):
        q[p * DIM : p * DIM + DIM] = pb["q_coef"][p] * dt
        e = pb["dr_idx"][p]
        if e >= 0:
            travel = np.linalg.norm(u[p])
            q[p * DIM : p * DIM + DIM] += pb["dr_q"][p, 3] * travel
            q[e : e + 3] = pb["dr_q"][p, :3] * dt
            q[e] += pb["dr_q"][p, 4] * travel
    return f(x_post), jac, np.diag(q)


@pytest.mark.parametrize(("seed", "block"), [(0, 7), (1, 1), (2, 200)])
def test_mbf_smoother_with_dr_states_equals_dense_extended_rts(seed: int, block: int) -> None:
    """With DR states the transition is nonlinear (F = I + E): the filter's prediction and
    the smoother's adjoint steps match the dense EKF/RTS recursion with F written out."""
    n_plat = 3
    pb = _with_dr(_problem(seed, n_plat), (0, 2))
    n_ep = pb["dt"].shape[0]
    rec = _all_slots(n_ep, n_plat)
    dr_rec = np.arange(n_ep, dtype=np.int64)

    def forward(block_: int) -> tuple[np.ndarray, ...]:
        return ekf_forward(  # type: ignore[no-any-return]
            pb["x0"],
            pb["c0"],
            *_kernel(pb),
            DIM,
            ROBUST,
            rec,
            block_,
            dr_rec,
            np.zeros(0),
            Reads(rec.ptr, rec.plat, dr_rec),
        )

    # with block 1 the checkpoint before epoch k + 1 is epoch k's posterior
    _, _, _, _, _, cp_x1, cp_c1, *_ = forward(1)
    post_x = cp_x1[1:]  # posteriors of epochs 0 .. K - 2 (the last epoch observes nothing)
    post_c = cp_c1[1:]
    last = n_ep - 2
    xs_ref = [post_x[last]]
    cs_ref = [post_c[last]]
    for k in range(last - 1, -1, -1):
        x_pred, jac, q = _dr_transition(pb, post_x[k], k + 1)
        c_pred = jac @ post_c[k] @ jac.T + q
        gain = post_c[k] @ jac.T @ np.linalg.inv(c_pred)
        xs_ref.append(post_x[k] + gain @ (xs_ref[-1] - x_pred))
        cs_ref.append(post_c[k] + gain @ (cs_ref[-1] - c_pred) @ gain.T)
    ref_x = np.array(xs_ref[::-1])
    ref_var = np.array([np.diag(c) for c in cs_ref[::-1]])
    # the last epoch has no observation: the filter's prediction to it is the dense one
    x_pred, jac, q = _dr_transition(pb, post_x[last], last + 1)
    _, _, gamma, _, _, cp_x, cp_c, dr_xf, dr_vf, *_ = forward(block)
    assert dr_xf[-1] == pytest.approx(x_pred[n_plat * DIM :], abs=1e-9)
    assert dr_vf[-1] == pytest.approx(np.diag(jac @ post_c[last] @ jac.T + q)[n_plat * DIM :])
    xs, var, dr_xs, dr_vs = mbf_backward(
        cp_x, cp_c, *_kernel(pb), gamma, DIM, rec, block, dr_rec=dr_rec
    )
    n_pos = n_plat * DIM
    assert xs.reshape(n_ep, -1)[:-1] == pytest.approx(ref_x[:, :n_pos], abs=1e-7)
    assert var.reshape(n_ep, -1)[:-1] == pytest.approx(ref_var[:, :n_pos], rel=1e-6, abs=1e-10)
    assert dr_xs[:-1] == pytest.approx(ref_x[:, n_pos:], abs=1e-7)
    assert dr_vs[:-1] == pytest.approx(ref_var[:, n_pos:], rel=1e-6, abs=1e-12)
    # the heading states moved off their prior: the test exercises the coupling
    assert np.abs(dr_xs[:, 0] - pb["x0"][n_pos]).max() > 1e-3


@pytest.mark.parametrize(("seed", "block"), [(0, 7), (1, 1), (4, 200), (5, 16)])
def test_deferred_dr_transitions_equal_the_eager_filter(seed: int, block: int) -> None:
    """A follower's transitions are applied when it is next read (dr_model, "Deferred
    transitions"): recording only the platforms each epoch observes, and the DR states
    every 9th epoch, gives the states and variances of the filter that applies every
    transition at once (every slot recorded: every follower read at every epoch), forward
    and smoothed; the heading states move, so a wrong gain or adjoint would show."""
    n_plat = 4
    pb = _with_dr(_problem(seed, n_plat, n_ep=90), (1, 2, 3))
    n_ep = pb["dt"].shape[0]
    every = _all_slots(n_ep, n_plat)
    # each platform recorded at the epochs an observation reads it (1 or 2 of 4 a range)
    counts, plats = [], []
    for k in range(n_ep):
        lo, hi = pb["ptr"][k], pb["ptr"][k + 1]
        seen = sorted(
            set(pb["a"][lo:hi].tolist())
            | set(pb["b"][lo:hi][pb["kind"][lo:hi] == OBS_RANGE].tolist())
        )
        counts.append(len(seen))
        plats.extend(seen)
    sparse = Slots(
        np.concatenate(([0], np.cumsum(counts))).astype(np.int64), np.array(plats, np.int64)
    )
    pick = np.array(
        [
            every.ptr[k] + p
            for k in range(n_ep)
            for p in plats[sum(counts[:k]) : sum(counts[: k + 1])]
        ]
    )
    dr_all = np.arange(n_ep, dtype=np.int64)
    dr_sparse = dr_all[::9].copy()

    def run(slots: Slots, dr_rec: np.ndarray) -> tuple[np.ndarray, ...]:
        out = ekf_forward(
            pb["x0"],
            pb["c0"],
            *_kernel(pb),
            DIM,
            ROBUST,
            slots,
            block,
            dr_rec,
            np.zeros(0),
            Reads(slots.ptr, slots.plat, dr_rec),
        )
        xf, vf, gamma, _, _, cp_x, cp_c, dr_xf, dr_vf = out[:9]
        xs, var, dr_xs, dr_vs = mbf_backward(
            cp_x, cp_c, *_kernel(pb), gamma, DIM, slots, block, dr_rec=dr_rec
        )
        return xf, vf, dr_xf, dr_vf, xs, var, dr_xs, dr_vs, gamma

    eager = run(every, dr_all)
    lazy = run(sparse, dr_sparse)
    assert lazy[8] == pytest.approx(eager[8], abs=1e-9)  # the same robust factors
    for i in (0, 1, 4, 5):  # the recorded slots, forward and smoothed
        assert lazy[i] == pytest.approx(eager[i][pick], rel=1e-8, abs=1e-10)
    for i in (2, 3, 6, 7):  # the DR states where both record them
        assert lazy[i] == pytest.approx(eager[i][dr_sparse], rel=1e-8, abs=1e-12)
    assert np.abs(lazy[6][:, 0] - pb["x0"][n_plat * DIM]).max() > 1e-3
