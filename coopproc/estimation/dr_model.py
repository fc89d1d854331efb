"""The dead-reckoning error states of the cooperative EKF: heading, heading rate, scale.

A platform's dead reckoning (INS/odometer) integrates its steps with a heading error
that grows (gyro bias, wheel slip) and an odometer scale error. A position-only state
(X_k = X_{k-1} + u_k, paper 002 eq. (12)-(13) with F = I) cannot estimate either: the
error it cannot see is inflated away as drift and accumulates in the directions the
ranges do not observe. With ``state = "dr"`` each follower carries three more states,
stacked after every platform's position (the position part of the state keeps its
layout, index ``p * dim + axis``):

- ``theta``: the heading correction (rad) that rotates the DR increments onto the truth;
- ``omega``: its rate (rad/s, minus the gyro bias of the DR's heading);
- ``s``: the odometer scale correction (the DR increments are (1 + s) times too short).

Process model (x posterior of epoch k - 1, u_k the platform's own navigation increment
between the epochs, east/north rotated, up unchanged)::

    p_k     = p_{k-1} + (1 + s) R(theta) u_k          R(theta): rotation about up
    theta_k = theta_{k-1} + omega_{k-1} dt_k
    omega_k = omega_{k-1}            (random walk: q_omega dt_k)
    s_k     = s_{k-1}                (random walk: q_s dt_k)

with theta also a random walk (q_theta dt_k: the angle random walk and the heading noise
of wheel odometry) and the position the residual white-velocity noise (q_p dt_k). The
Jacobian F = I + E has, per follower, E[p_e, theta] = -(1 + s) (R u)_n,
E[p_n, theta] = (1 + s) (R u)_e, E[p_{e,n}, s] = (R u)_{e,n} and E[theta, omega] = dt:
five entries, so C <- F C F^T + Q costs O(n) per follower (:func:`touch`) and the
smoother's adjoints (lambda <- F^T lambda, Lambda <- F^T Lambda F, :func:`adjoint_touch`)
the same. Where no platform has these states (``state = "position"``, paper 000's own
fusion) the transition is the identity and the arithmetic is that of the position-only
filter, bit for bit.

Deferred transitions (issue 29.6). A follower's rows and columns of C change only
through its own transition, and an observation reads only the platforms it involves, so
the transition of a follower no observation reads is not applied to C at every epoch:
its epochs' F multiply into one pending G = F_k ... F_j = I + A (:func:`dr_predict`; A
has seven entries: the positions' theta, omega and s columns, theta's omega column) and
C holds the covariance with the pending transitions not applied, C_true = G C G^T.
Every product the filter forms stays exact: an observation of platforms whose G is I
has C_true h = G (C h) and h C_true h^T = h C h^T, so the scalar update of C is the
update of C_true with the pending G taken out, and the state's own update gains G (C h)
(:func:`pending_gain`: the mean is always the true one, propagated at every epoch). The
process noise Q of an epoch goes to the follower's pending noise S as G^-1 Q G^-T
(:func:`fold_noise`; C_true = G (C + S) G^T; the positions' columns of G are I's, so
their noise is added to C as it is), and G and S are applied to C when the follower is
next observed or recorded (:func:`touch`: C <- G (C + S) G^T, O(n) per follower, the
cost one epoch's transition had). S and the observations never meet: an observation's h
is 0 on a pending follower, so S h = 0. The smoother's time steps are the same touches
in reverse (:func:`adjoint_touch`). With 19 followers and one range per epoch, two
followers are touched per epoch instead of 19 transitions.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = [
    "DR_STATES",
    "PEND",
    "adjoint_touch",
    "adjoint_touch_vector",
    "dr_predict",
    "fold_noise",
    "pending_gain",
    "touch",
]

#: States per follower: heading correction, its rate, odometer scale correction.
DR_STATES = 3

#: A follower's pending transition (:func:`dr_predict`): a flag (1.0: G is not I), then
#: A's entries (p_e: theta, omega, s; p_n: theta, omega, s; theta: omega), then the
#: pending noise S's upper triangle over (east, north, theta, omega, s) (:func:`fold_noise`).
PEND = 23

IntArray = NDArray[np.int64]


@numba.njit(cache=True, nogil=True)
def dr_predict(
    x: FloatArray,
    i0: int,
    e: int,
    ue: float,
    un: float,
    dt_k: float,
    g: FloatArray,
) -> None:
    """One follower's DR-state prediction: the mean (rotated, scaled increment; the heading
    integrates its rate), in place, and the epoch's F = I + E multiplied into the pending
    G = I + A (``g``, :data:`PEND` values: F G = I + E + A + E A).

    ``i0``: index of the platform's east state (north at ``i0 + 1``); ``e``: its heading
    correction (rate at ``e + 1``, scale at ``e + 2``); ``ue``/``un``: its own navigation
    increment. The process noise is added by the caller (:func:`fold_noise`).
    """
    theta = x[e]
    s1 = 1.0 + x[e + 2]
    ct = np.cos(theta)
    st = np.sin(theta)
    rue = ct * ue - st * un
    run = st * ue + ct * un
    je = -s1 * run  # d/dtheta of (1 + s) R(theta) u
    jn = s1 * rue
    x[i0] += s1 * rue
    x[i0 + 1] += s1 * run
    x[e] += x[e + 1] * dt_k
    a_tw = g[7]  # E A: the positions' theta entries times A's theta row (its omega entry)
    g[0] = 1.0
    g[1] += je
    g[2] += je * a_tw
    g[3] += rue
    g[4] += jn
    g[5] += jn * a_tw
    g[6] += run
    g[7] = a_tw + dt_k


@numba.njit(cache=True, nogil=True)
def fold_noise(g: FloatArray, q_t: float, q_w: float, q_s: float) -> None:
    """Add the DR states' process noise diag(q_t, q_w, q_s) of this epoch to the pending
    noise S as G^-1 Q G^-T (``g``'s pending G: C_true = G (C + S) G^T gains Q; S is added to
    C when the follower is touched, :func:`touch`).

    G^-1's theta, omega and s columns (G is unit triangular): y_t = (-a_et, -a_nt, 1, 0, 0),
    y_w = (a_et a_tw - a_ew, a_nt a_tw - a_nw, -a_tw, 1, 0), y_s = (-a_es, -a_ns, 0, 0, 1)
    over (east, north, theta, omega, s); with nothing pending they are unit vectors. S is
    kept as its upper triangle, row by row, in ``g[8:23]``.
    """
    a_et, a_ew, a_es, a_nt, a_nw, a_ns, a_tw = g[1], g[2], g[3], g[4], g[5], g[6], g[7]
    te, tn = -a_et, -a_nt  # y_t's position entries (its theta entry 1)
    we, wn, wt = a_et * a_tw - a_ew, a_nt * a_tw - a_nw, -a_tw  # y_w's (omega 1)
    se, sn = -a_es, -a_ns  # y_s's (s 1)
    g[8] += q_t * te * te + q_w * we * we + q_s * se * se  # (e, e)
    g[9] += q_t * te * tn + q_w * we * wn + q_s * se * sn  # (e, n)
    g[10] += q_t * te + q_w * we * wt  # (e, theta)
    g[11] += q_w * we  # (e, omega)
    g[12] += q_s * se  # (e, s)
    g[13] += q_t * tn * tn + q_w * wn * wn + q_s * sn * sn  # (n, n)
    g[14] += q_t * tn + q_w * wn * wt  # (n, theta)
    g[15] += q_w * wn  # (n, omega)
    g[16] += q_s * sn  # (n, s)
    g[17] += q_t + q_w * wt * wt  # (theta, theta)
    g[18] += q_w * wt  # (theta, omega)
    # (theta, s) and (omega, s), g[19] and g[21], stay 0
    g[20] += q_w  # (omega, omega)
    g[22] += q_s  # (s, s)


@numba.njit(cache=True, nogil=True)
def _add_noise(m: FloatArray, i0: int, e: int, g: FloatArray) -> None:
    """M += S, the pending noise of ``g`` (:func:`fold_noise`), symmetric bit for bit."""
    idx = (i0, i0 + 1, e, e + 1, e + 2)
    at = 8
    for u in range(5):
        m[idx[u], idx[u]] += g[at]
        at += 1
        for w in range(u + 1, 5):
            m[idx[u], idx[w]] += g[at]
            m[idx[w], idx[u]] += g[at]
            at += 1


@numba.njit(cache=True, nogil=True)
def pending_gain(
    x: FloatArray, ph: FloatArray, i0: int, e: int, g: FloatArray, coef: float
) -> None:
    """The state update of a follower with a pending G beyond C's: x += A (C h) coef (the
    caller added (C h) coef to every state: together G (C h) coef, the true gain)."""
    t = ph[e]
    w = ph[e + 1]
    s = ph[e + 2]
    x[i0] += (g[1] * t + g[2] * w + g[3] * s) * coef
    x[i0 + 1] += (g[4] * t + g[5] * w + g[6] * s) * coef
    x[e] += g[7] * w * coef


@numba.njit(cache=True, nogil=True)
def touch(m: FloatArray, i0: int, e: int, g: FloatArray) -> None:
    """M <- G (M + S) G^T for the pending G = I + A and noise S of one follower (``g``), in
    place, for a symmetric M (the filter's covariance): the result is symmetric bit for
    bit; then G = I, S = 0.

    G changes the rows and columns B = (east, north, theta). Rows first, contiguously
    (N = G M: each position row gains A's entries times the theta, omega and s rows, read
    before the theta row gains a_tw times the omega row); then, M being symmetric, the
    columns B of every other row are those rows of N (copied, not recomputed); the B x B
    block takes A's columns too, N[a, b] + sum_l A[b, l] N[a, l], averaged with its
    transpose. One epoch's F (A = E) is the transition C <- F C F^T.
    """
    _add_noise(m, i0, e, g)
    a_et, a_ew, a_es, a_nt, a_nw, a_ns, a_tw = g[1], g[2], g[3], g[4], g[5], g[6], g[7]
    n = m.shape[0]
    for j in range(n):
        m_t = m[e, j]
        m_w = m[e + 1, j]
        m_s = m[e + 2, j]
        m[i0, j] += a_et * m_t + a_ew * m_w + a_es * m_s
        m[i0 + 1, j] += a_nt * m_t + a_nw * m_w + a_ns * m_s
        m[e, j] = m_t + a_tw * m_w
    b00, b01, b02 = _block_row(m, i0, i0, e, g)
    b10, b11, b12 = _block_row(m, i0 + 1, i0, e, g)
    b20, b21, b22 = _block_row(m, e, i0, e, g)
    for i in range(n):  # the columns B of the other rows: N's rows B
        if i != i0 and i != i0 + 1 and i != e:
            m[i, i0] = m[i0, i]
            m[i, i0 + 1] = m[i0 + 1, i]
            m[i, e] = m[e, i]
    m[i0, i0] = b00
    m[i0 + 1, i0 + 1] = b11
    m[e, e] = b22
    m[i0, i0 + 1] = m[i0 + 1, i0] = 0.5 * (b01 + b10)
    m[i0, e] = m[e, i0] = 0.5 * (b02 + b20)
    m[i0 + 1, e] = m[e, i0 + 1] = 0.5 * (b12 + b21)
    for j in range(PEND):
        g[j] = 0.0


@numba.njit(cache=True, nogil=True, inline="always")
def _block_row(m: FloatArray, r: int, i0: int, e: int, g: FloatArray) -> tuple[float, float, float]:
    """Row r of N G^T at the columns (east, north, theta), N = G M the row-passed M."""
    n_t = m[r, e]
    n_w = m[r, e + 1]
    n_s = m[r, e + 2]
    return (
        m[r, i0] + (g[1] * n_t + g[2] * n_w + g[3] * n_s),
        m[r, i0 + 1] + (g[4] * n_t + g[5] * n_w + g[6] * n_s),
        n_t + g[7] * n_w,
    )


@numba.njit(cache=True, nogil=True)
def adjoint_touch_vector(lam: FloatArray, i0: int, e: int, g: FloatArray) -> None:
    """lambda <- G^T lambda of :func:`adjoint_touch` alone: the smoother pass that forms
    no variance carries lambda only (:mod:`~coopproc.stages.fusion.smoother`)."""
    a_et, a_ew, a_es, a_nt, a_nw, a_ns, a_tw = g[1], g[2], g[3], g[4], g[5], g[6], g[7]
    lam[e + 1] += a_ew * lam[i0] + a_nw * lam[i0 + 1] + a_tw * lam[e]
    lam[e] += a_et * lam[i0] + a_nt * lam[i0 + 1]
    lam[e + 2] += a_es * lam[i0] + a_ns * lam[i0 + 1]


@numba.njit(cache=True, nogil=True)
def adjoint_touch(lam: FloatArray, lam_t: FloatArray, i0: int, e: int, g: FloatArray) -> None:
    """The smoother's step back through one follower's touch (G = I + A of ``g``, as
    :func:`touch` applied it), in place: lambda <- G^T lambda and Lambda <- G^T Lambda G,
    for a symmetric Lambda (the smoother keeps it so, :mod:`~coopproc.stages.fusion.smoother`):
    the result is symmetric bit for bit.

    (G^T lambda)_j = lambda_j + sum_i A[i, j] lambda_i: the omega entry takes a_tw times the
    heading entry before that gains the position entries' share. G^T changes the rows and
    columns B = (theta, omega, s): rows first, contiguously (N = G^T Lambda); the columns B
    of every other row are N's rows B (Lambda symmetric); the B x B block takes A's rows
    too, N[a, b] + sum_i N[a, i] A[i, b], averaged with its transpose.
    """
    adjoint_touch_vector(lam, i0, e, g)
    a_et, a_ew, a_es, a_nt, a_nw, a_ns, a_tw = g[1], g[2], g[3], g[4], g[5], g[6], g[7]
    n = lam_t.shape[0]
    for j in range(n):  # rows: G^T M
        m_e = lam_t[e, j]
        m_pe = lam_t[i0, j]
        m_pn = lam_t[i0 + 1, j]
        lam_t[e + 1, j] += a_ew * m_pe + a_nw * m_pn + a_tw * m_e
        lam_t[e, j] = m_e + a_et * m_pe + a_nt * m_pn
        lam_t[e + 2, j] += a_es * m_pe + a_ns * m_pn
    b00, b01, b02 = _adjoint_row(lam_t, e, i0, e, g)
    b10, b11, b12 = _adjoint_row(lam_t, e + 1, i0, e, g)
    b20, b21, b22 = _adjoint_row(lam_t, e + 2, i0, e, g)
    for i in range(n):  # the columns B of the other rows: N's rows B
        if i < e or i > e + 2:
            lam_t[i, e] = lam_t[e, i]
            lam_t[i, e + 1] = lam_t[e + 1, i]
            lam_t[i, e + 2] = lam_t[e + 2, i]
    lam_t[e, e] = b00
    lam_t[e + 1, e + 1] = b11
    lam_t[e + 2, e + 2] = b22
    lam_t[e, e + 1] = lam_t[e + 1, e] = 0.5 * (b01 + b10)
    lam_t[e, e + 2] = lam_t[e + 2, e] = 0.5 * (b02 + b20)
    lam_t[e + 1, e + 2] = lam_t[e + 2, e + 1] = 0.5 * (b12 + b21)


@numba.njit(cache=True, nogil=True, inline="always")
def _adjoint_row(
    m: FloatArray, r: int, i0: int, e: int, g: FloatArray
) -> tuple[float, float, float]:
    """Row r of N G at the columns (theta, omega, s), N = G^T M the row-passed M."""
    m_e = m[r, e]
    m_pe = m[r, i0]
    m_pn = m[r, i0 + 1]
    return (
        m_e + g[1] * m_pe + g[4] * m_pn,
        m[r, e + 1] + g[2] * m_pe + g[5] * m_pn + g[7] * m_e,
        m[r, e + 2] + g[3] * m_pe + g[6] * m_pn,
    )
