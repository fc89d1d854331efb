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
five entries, so C <- F C F^T + Q costs O(n) per follower (:func:`congruence`) and the
smoother's adjoints (lambda <- F^T lambda, Lambda <- F^T Lambda F, :func:`adjoint_step`)
the same. Where no platform has these states (``state = "position"``, paper 000's own
fusion) the transition is the identity and the arithmetic is that of the position-only
filter, bit for bit.

The four entries of E that depend on the epoch, ``(E[p_e, theta], E[p_n, theta],
E[p_e, s], E[p_n, s])``, are written to ``f_out[p]`` by :func:`dr_predict` so that the
smoother re-run hands them to the backward pass.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.model import FloatArray

__all__ = ["DR_STATES", "adjoint_step", "congruence", "dr_predict"]

#: States per follower: heading correction, its rate, odometer scale correction.
DR_STATES = 3

IntArray = NDArray[np.int64]


@numba.njit(cache=True, nogil=True)
def dr_predict(
    x: FloatArray,
    c: FloatArray,
    i0: int,
    e: int,
    ue: float,
    un: float,
    dt_k: float,
    f_out: FloatArray,
) -> None:
    """One follower's DR-state prediction: the mean (rotated, scaled increment; the heading
    integrates its rate) and C <- F C F^T, in place; E's four epoch entries to ``f_out``.

    ``i0``: index of the platform's east state (north at ``i0 + 1``); ``e``: its heading
    correction (rate at ``e + 1``, scale at ``e + 2``); ``ue``/``un``: its own navigation
    increment. The process noise is added by the caller.
    """
    theta = x[e]
    s1 = 1.0 + x[e + 2]
    ct = np.cos(theta)
    st = np.sin(theta)
    rue = ct * ue - st * un
    run = st * ue + ct * un
    je = -s1 * run  # d/dtheta of (1 + s) R(theta) u
    jn = s1 * rue
    f_out[0] = je
    f_out[1] = jn
    f_out[2] = rue
    f_out[3] = run
    x[i0] += s1 * rue
    x[i0 + 1] += s1 * run
    x[e] += x[e + 1] * dt_k
    congruence(c, i0, e, je, jn, rue, run, dt_k)


@numba.njit(cache=True, nogil=True)
def congruence(
    m: FloatArray, i0: int, e: int, je: float, jn: float, rue: float, run: float, dt_k: float
) -> None:
    """M <- F M F^T for F = I + E of one follower (see the module doc), in place, for a
    symmetric M (the filter's covariance): the result is symmetric bit for bit.

    F changes the rows and columns A = (east, north, theta). Rows first, contiguously
    (N = F M: each position row gains E's entries times the theta and s rows, read before
    the theta row gains dt times the omega row); then, M being symmetric, the columns A
    of every other row are those rows of N (copied, not recomputed); the A x A block takes
    E's columns too, N[a, b] + sum_l E[b, l] N[a, l], averaged with its transpose.
    """
    n = m.shape[0]
    for j in range(n):
        m_t = m[e, j]
        m_s = m[e + 2, j]
        m[i0, j] += je * m_t + rue * m_s
        m[i0 + 1, j] += jn * m_t + run * m_s
        m[e, j] += dt_k * m[e + 1, j]
    # the A x A block, row a of it from N's row a (east, north, theta)
    b00, b01, b02 = _block_row(m, i0, i0, e, je, jn, rue, run, dt_k)
    b10, b11, b12 = _block_row(m, i0 + 1, i0, e, je, jn, rue, run, dt_k)
    b20, b21, b22 = _block_row(m, e, i0, e, je, jn, rue, run, dt_k)
    for i in range(n):  # the columns A of the other rows: N's rows A
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


@numba.njit(cache=True, nogil=True, inline="always")
def _block_row(
    m: FloatArray,
    r: int,
    i0: int,
    e: int,
    je: float,
    jn: float,
    rue: float,
    run: float,
    dt_k: float,
) -> tuple[float, float, float]:
    """Row r of N F^T at the columns (east, north, theta), N = F M the row-passed M."""
    n_t = m[r, e]
    n_s = m[r, e + 2]
    return (
        m[r, i0] + (je * n_t + rue * n_s),
        m[r, i0 + 1] + (jn * n_t + run * n_s),
        n_t + dt_k * m[r, e + 1],
    )


@numba.njit(cache=True, nogil=True)
def adjoint_step(
    lam: FloatArray,
    lam_t: FloatArray,
    i0: int,
    e: int,
    je: float,
    jn: float,
    rue: float,
    run: float,
    dt_k: float,
) -> None:
    """The smoother's time step back through one follower's transition, in place:
    lambda <- F^T lambda and Lambda <- F^T Lambda F, for a symmetric Lambda (the smoother
    keeps it so, :mod:`~coopproc.stages.fusion.smoother`): the result is symmetric bit
    for bit.

    (F^T lambda)_j = lambda_j + sum_i E[i, j] lambda_i: the omega entry takes dt times the
    heading entry before that gains the position entries' share. F^T changes the rows and
    columns B = (theta, omega, s): rows first, contiguously (N = F^T Lambda); the columns B
    of every other row are N's rows B (Lambda symmetric); the B x B block takes E's rows
    too, N[a, b] + sum_i E[i, b] N[a, i], averaged with its transpose.
    """
    lam[e + 1] += dt_k * lam[e]
    lam[e] += je * lam[i0] + jn * lam[i0 + 1]
    lam[e + 2] += rue * lam[i0] + run * lam[i0 + 1]
    n = lam_t.shape[0]
    for j in range(n):  # rows: F^T M
        m_e = lam_t[e, j]
        lam_t[e + 1, j] += dt_k * m_e
        lam_t[e, j] = m_e + je * lam_t[i0, j] + jn * lam_t[i0 + 1, j]
        lam_t[e + 2, j] += rue * lam_t[i0, j] + run * lam_t[i0 + 1, j]
    b00, b01, b02 = _adjoint_row(lam_t, e, i0, e, je, jn, rue, run, dt_k)
    b10, b11, b12 = _adjoint_row(lam_t, e + 1, i0, e, je, jn, rue, run, dt_k)
    b20, b21, b22 = _adjoint_row(lam_t, e + 2, i0, e, je, jn, rue, run, dt_k)
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
    m: FloatArray,
    r: int,
    i0: int,
    e: int,
    je: float,
    jn: float,
    rue: float,
    run: float,
    dt_k: float,
) -> tuple[float, float, float]:
    """Row r of N F at the columns (theta, omega, s), N = F^T M the row-passed M."""
    m_e = m[r, e]
    return (
        m_e + je * m[r, i0] + jn * m[r, i0 + 1],
        m[r, e + 1] + dt_k * m_e,
        m[r, e + 2] + rue * m[r, i0] + run * m[r, i0 + 1],
    )
