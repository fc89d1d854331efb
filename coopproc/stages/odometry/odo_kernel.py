"""The compiled loops of the odometer/UWB filter (:mod:`coopproc.stages.odometry.odo_uwb`).

State X = [east, north, psi, s_v, s_w, b_w, b_r] (m, m, rad heading from east counter-
clockwise, odometer speed scale, yaw-rate scale, yaw-rate bias rad/s, a range bias m
common to all anchors: antenna delay). Step k predicts
from t_{k-1} to t_k with the odometer sample held over that interval (v_k, w_k: the
sample at or before t_{k-1}, zero-order hold forward), then updates with the ranges to
anchors taken at t_k, one at a time.

Prediction (unicycle, midpoint heading):

    w = s_w w_k + b_w,  d = s_v v_k dt,  m = psi + w dt / 2
    east += d cos m,  north += d sin m,  psi += w dt

Process noise: the distance increment d with variance q_d dt and the heading increment
with variance q_psi dt (white wheel-speed noise of 1-sigma sigma_v, sigma_w per sample
of interval T: q = sigma^2 T), mapped through the Jacobian of the increments; a random
walk q_pos dt per position axis (slip, body motion); random walks q_cal dt on the four
calibration states.

Range update: r = |(e, n, up) - anchor| + b_r with the IGG-III robust factor (paper 002 eq.
(18)) on the innovation standardized by sqrt(H C H^T + R) and by the MAD of the last
``window`` standardized innovations, floor 1 (eq. (19)-(20), as the cooperative fusion and
:mod:`coopproc.stages.anchors.uwb_kf`); R -> R / gamma; Joseph form.

The negative log-likelihood sum(log S + min(V^2 / S, k1^2)) of the raw innovations is
returned for the maximum-likelihood choice of the initial heading, yaw-rate scale and
wheel-speed noise.
"""

from __future__ import annotations

import numba
import numpy as np

from coopproc.estimation.range_model import range_unit
from coopproc.estimation.robust import GAMMA_REJECT, igg3_scalar, mad_sigma_nb
from coopproc.model import FloatArray

__all__ = ["N_STATE", "odo_forward"]

#: east, north, psi, speed scale, yaw-rate scale, yaw-rate bias, range bias
N_STATE = 7


@numba.njit(cache=True)
def _predict(
    x: FloatArray, c: FloatArray, f: FloatArray, dt: float, v_o: float, w_o: float, q: FloatArray
) -> None:
    """X, C <- the prediction over dt (in place); F <- the transition Jacobian.
    Plain loops: they compile in a fraction of the time of small-matrix numpy calls."""
    w = x[4] * w_o + x[5]
    d = x[3] * v_o * dt
    m = x[2] + 0.5 * w * dt
    cm, sm = np.cos(m), np.sin(m)
    x[0] += d * cm
    x[1] += d * sm
    x[2] += w * dt
    n = N_STATE
    for i in range(n):
        for j in range(n):
            f[i, j] = 1.0 if i == j else 0.0
    f[0, 2] = -d * sm
    f[1, 2] = d * cm
    f[0, 3] = v_o * dt * cm
    f[1, 3] = v_o * dt * sm
    f[0, 4] = -d * sm * 0.5 * w_o * dt
    f[1, 4] = d * cm * 0.5 * w_o * dt
    f[0, 5] = -d * sm * 0.5 * dt
    f[1, 5] = d * cm * 0.5 * dt
    f[2, 4] = w_o * dt
    f[2, 5] = dt
    # C <- F C F^T (F differs from I in rows 0..2 only)
    fc = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += f[i, k] * c[k, j]
            fc[i, j] = acc
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += fc[i, k] * f[j, k]
            c[i, j] = acc
            c[j, i] = acc
    # + Q: the distance increment (q[0] dt) along gd, the heading increment (q[1] dt)
    # along gp, position random walk, calibration random walks
    gd0, gd1 = cm, sm
    gp0, gp1 = -0.5 * d * sm, 0.5 * d * cm
    qd, qp = q[0] * dt, q[1] * dt
    c[0, 0] += qd * gd0 * gd0 + qp * gp0 * gp0 + q[2] * dt
    c[1, 1] += qd * gd1 * gd1 + qp * gp1 * gp1 + q[2] * dt
    c[0, 1] += qd * gd0 * gd1 + qp * gp0 * gp1
    c[1, 0] = c[0, 1]
    c[0, 2] += qp * gp0
    c[2, 0] = c[0, 2]
    c[1, 2] += qp * gp1
    c[2, 1] = c[1, 2]
    c[2, 2] += qp
    for i in range(4):
        c[3 + i, 3 + i] += q[3 + i] * dt


@numba.njit(cache=True)
def _update(x: FloatArray, c: FloatArray, h: FloatArray, v: float, r: float) -> None:
    """X, C <- the scalar update with innovation v, design row h, variance r (in place),
    Joseph form (I - K h) C (I - K h)^T + K r K^T = C - K (C h)^T - (C h) K^T + K s K^T."""
    n = N_STATE
    ch = np.zeros(n)
    for i in range(n):
        for j in range(n):
            ch[i] += c[i, j] * h[j]
    s = r
    for i in range(n):
        s += h[i] * ch[i]
    gain = ch / s
    for i in range(n):
        x[i] += gain[i] * v
    for i in range(n):
        for j in range(i, n):
            val = c[i, j] - gain[i] * ch[j] - ch[i] * gain[j] + gain[i] * gain[j] * s
            c[i, j] = val
            c[j, i] = val


@numba.njit(cache=True)
def odo_forward(
    t: FloatArray,
    v_o: FloatArray,
    w_o: FloatArray,
    ptr: np.ndarray,
    anchor: FloatArray,
    rng: FloatArray,
    var: FloatArray,
    up: FloatArray,
    x0: FloatArray,
    c0: FloatArray,
    q: FloatArray,
    robust: bool,
    k0: float,
    k1: float,
    window: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The forward filter (module docstring).

    ``t`` (K,) step times; ``v_o``, ``w_o`` (K,) the odometer speed and yaw rate held over
    (t_{k-1}, t_k]; ``ptr`` (K + 1,) the ranges of step k are rows ptr[k]:ptr[k+1] of
    ``anchor`` (R, 3), ``rng``, ``var`` (R,); ``up`` (K,) the platform's height; ``q``
    (7,) = q_d, q_psi, q_pos, q_sv, q_sw, q_bw, q_br.

    Returns filtered X (K, 7), C (K, 7, 7), predicted X, C, F (K, 7, 7), per range
    [innovation, its variance S, gamma] (R, 3), and [nll] (1,).
    """
    k_n = t.shape[0]
    n = N_STATE
    xf = np.zeros((k_n, n))
    cf = np.zeros((k_n, n, n))
    xp = np.zeros((k_n, n))
    cp = np.zeros((k_n, n, n))
    fs = np.zeros((k_n, n, n))
    innov = np.full((rng.shape[0], 3), np.nan)
    hist = np.zeros(window)
    pool = np.empty(window + 1)
    ones = np.ones(window + 1)
    n_hist = 0
    nll = 0.0
    x = x0.copy()
    c = c0.copy()
    f = np.eye(n)
    h = np.zeros(n)
    diff = np.zeros(3)
    for k in range(k_n):
        if k > 0:
            _predict(x, c, f, t[k] - t[k - 1], v_o[k], w_o[k], q)
            fs[k] = f
        else:
            fs[k] = np.eye(n)
        xp[k], cp[k] = x, c
        for j in range(ptr[k], ptr[k + 1]):
            diff[0] = x[0] - anchor[j, 0]
            diff[1] = x[1] - anchor[j, 1]
            diff[2] = up[k] - anchor[j, 2]
            rho = range_unit(diff, 0.0, diff)
            h[0], h[1], h[6] = diff[0], diff[1], 1.0  # the range bias x[6]: d h / d b = 1
            v = rng[j] - rho - x[6]
            s_raw = var[j]
            for a in range(n):
                for b in range(n):
                    s_raw += h[a] * c[a, b] * h[b]
            nll += np.log(s_raw) + min(v * v / s_raw, k1 * k1)
            g = 1.0
            if robust:
                wst = v / np.sqrt(s_raw)
                used = min(n_hist, window)
                pool[:used] = hist[:used]
                pool[used] = wst
                sigma = mad_sigma_nb(pool[: used + 1], ones[: used + 1], 1.0)
                g = igg3_scalar(wst / sigma, k0, k1)
                hist[n_hist % window] = wst
                n_hist += 1
            innov[j, 0], innov[j, 1], innov[j, 2] = v, s_raw, g
            if g > GAMMA_REJECT:
                _update(x, c, h, v, var[j] / g)
        xf[k], cf[k] = x, c
    out = np.array([nll])
    return xf, cf, xp, cp, fs, innov, out
