"""Tightly coupled UWB-only positioning: each range to an anchor updates a constant-velocity
EKF (methods ``range_kf``, ``range_rts``; issue 31).

``lsq_kf`` / ``lsq_rts`` (:mod:`coopproc.stages.anchors.uwb_kf`) filter least-squares
fixes, so they need ``dims + 1`` anchors ranged within one epoch. Anchors polled one at a
time (miluv1: six anchors in turn at 4.6 Hz, one range per anchor every 1.3 s) almost
never give that: ``lsq`` fixed the drone at one epoch of its 207 s flight. Here the state
X = [p; v] (d = 2 or 3 axes, the model of uwb_kf.py: F, Q with white-acceleration PSD
``range_accel_psd``) is updated by every range on its own:

    r = |p - a| (+ the height difference for a planar platform, d = 2),
    H = [u^T 0],  u = (p - a) / r,  R = sigma^2,

with the IGG-III factor (paper 002 eq. (18)-(20), ``kf_k0``, ``kf_k1``) on the innovation
standardized by sqrt(H C H^T + R) and the MAD of the last ``MAD_WINDOW`` of them, as
``lsq_kf``. Dimension: 2 at a known height (session.toml ``height``, or the
navigation's, or ``planar = true`` with the height of the fixes, :mod:`~coopproc.stages.
anchors.anchor_lsq`), else 3 (the height is estimated as a state: miluv1's drone flies
0-3 m high, at the fixes' one estimated height its RMSE is 0.64 m, in 3-D 0.23 m). Start: the
first accepted least-squares fix and its covariance when it comes within
``rate_max_gap_s`` of the first range (the filter starts there); else the anchors'
centroid +- ``START_SIGMA_M`` at the first range. The smoother is uwb_kf.py's RTS.
Positions at each distinct range time.

Measured (``coopproc run``): miluv1 as a tag, 3-D, 100 % of the flight, 0.23 m
horizontal RMSE; hanyang_los 0.68 m (``lsq_rts`` 0.69 m).
"""

from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np
import pandas as pd

from coopproc.estimation.range_model import range_unit
from coopproc.estimation.robust import igg3_scalar, mad_sigma_nb
from coopproc.model import FloatArray, Session, Trajectory
from coopproc.stages.anchors.anchor_lsq import anchor_fixes
from coopproc.stages.anchors.uwb_kf import MAD_WINDOW, V0_SIGMA_MPS, _backward, _transition
from coopproc.stages.shared.data import anchor_positions, clean_ranges, range_sigma_default
from coopproc.stages.shared.lsq import LsqParams

__all__ = ["START_SIGMA_M", "range_kf_positions"]

#: 1-sigma (m) of the start position when no least-squares fix starts the filter.
START_SIGMA_M = 10.0
#: 1-sigma (m) of the start height of a 3-D filter started from a fix at one height.
HEIGHT_SIGMA_M = 1.0


@numba.njit(cache=True)
def _forward(
    t: FloatArray,
    rng: FloatArray,
    var: FloatArray,
    anchor: FloatArray,
    up: FloatArray,
    x0: FloatArray,
    c0: FloatArray,
    q: float,
    robust: bool,
    k0: float,
    k1: float,
    window: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    k_n = t.shape[0]
    d = x0.shape[0]
    n = 2 * d
    xf = np.zeros((k_n, n))
    cf = np.zeros((k_n, n, n))
    xp = np.zeros((k_n, n))
    cp = np.zeros((k_n, n, n))
    gam = np.ones(k_n)
    x = np.zeros(n)
    c = np.zeros((n, n))
    x[:d] = x0
    c[:d, :d] = c0
    for i in range(d):
        c[d + i, d + i] = V0_SIGMA_MPS**2
    hist = np.zeros(window)
    n_hist = 0
    t_prev = t[0]
    for k in range(k_n):
        f, qm = _transition(t[k] - t_prev, d, q)
        t_prev = t[k]
        x = f @ x
        c = f @ c @ f.T + qm
        xp[k], cp[k] = x, c
        h = np.zeros(n)
        for i in range(d):
            h[i] = x[i] - anchor[k, i]
        dz2 = (up[k] - anchor[k, 2]) ** 2 if d == 2 else 0.0
        rho = range_unit(h[:d], dz2, h[:d])
        v = rng[k] - rho
        ch = c @ h
        s = h @ ch + var[k]
        g = 1.0
        if robust:
            w = v / np.sqrt(s)
            used = min(n_hist, window)
            pool = np.empty(used + 1)
            pool[:used] = hist[:used]
            pool[used] = w
            sigma = mad_sigma_nb(pool, np.ones(used + 1), 1.0)
            g = igg3_scalar(w / sigma, k0, k1)
            hist[n_hist % window] = w
            n_hist += 1
        r = var[k] / g
        s = h @ ch + r
        gain = ch / s
        x = x + gain * v
        ikh = np.eye(n) - np.outer(gain, h)
        c = ikh @ c @ ikh.T + np.outer(gain, gain) * r  # Joseph form
        c = 0.5 * (c + c.T)
        xf[k], cf[k] = x, c
        gam[k] = g
    return xf, cf, xp, cp, gam


def range_kf_positions(
    session: Session, ranges: pd.DataFrame, params: LsqParams, *, smooth: bool
) -> Mapping[str, Trajectory]:
    """Every platform ranging to anchors, filtered (and smoothed) range by range; at each
    distinct range time, platform id -> Trajectory with velocity."""
    anchors = anchor_positions(session)
    rows = clean_ranges(session, ranges, range_sigma_default(session, params.range_sigma_m))
    a_from = rows["from"].isin(list(anchors)).to_numpy()
    keep = a_from ^ rows["to"].isin(list(anchors)).to_numpy()
    rows, a_from = rows[keep], a_from[keep]
    tag = np.where(a_from, rows["to"].to_numpy(), rows["from"].to_numpy())
    other = np.where(a_from, rows["from"].to_numpy(), rows["to"].to_numpy())
    solution = anchor_fixes(session, ranges, params)
    centroid = np.mean(np.stack(list(anchors.values())), axis=0)
    out: dict[str, Trajectory] = {}
    for pid in sorted(set(tag.tolist())):
        mine = tag == pid
        t = rows["time"].to_numpy()[mine]
        if t.shape[0] < 2:
            continue
        dim, height_t, height = solution.geometry[pid]
        declared, planar = session.platforms[pid].antenna
        if declared is None and planar is None and not len(session.nav.get(pid, ())):
            dim = 3  # the height unknown: a state, estimated (a drone is not planar)
        up = np.interp(t, height_t, height) if dim == 2 else np.zeros(t.shape[0])
        fix = solution.fixes.get(pid)
        x0, c0 = centroid[:dim], np.eye(dim) * START_SIGMA_M**2
        start = 0
        if fix is not None and fix.time_s[0] - t[0] <= params.rate_max_gap_s:
            start = int(np.searchsorted(t, fix.time_s[0]))
            x0, c0 = np.append(fix.pos[0], fix.up[0])[:dim], np.eye(dim) * HEIGHT_SIGMA_M**2
            c0[:2, :2] = fix.cov[0][:2, :2]
        t = np.ascontiguousarray(t[start:])
        a_xyz = np.stack([anchors[a] for a in other[mine][start:]])
        xf, cf, xp, cp, _ = _forward(
            t, rows["range"].to_numpy()[mine][start:], rows["var"].to_numpy()[mine][start:],
            a_xyz, up[start:], np.asarray(x0, dtype=np.float64),
            np.ascontiguousarray(c0, dtype=np.float64), float(params.range_accel_psd),
            bool(params.kf_robust), float(params.kf_k0), float(params.kf_k1), MAD_WINDOW,
        )  # fmt: skip
        x, c = _backward(t, xf, cf, xp, cp, dim) if smooth else (xf, cf)
        last = np.r_[t[1:] != t[:-1], True]  # the state after a time's last range
        enu = np.zeros((int(last.sum()), 3))
        vel = np.zeros_like(enu)
        sig = np.full_like(enu, np.nan)
        enu[:, :dim], vel[:, :dim] = x[last, :dim], x[last, dim:]
        sig[:, :dim] = np.sqrt(np.maximum(np.einsum("kii->ki", c[last])[:, :dim], 0.0))
        if dim == 2:
            enu[:, 2] = up[start:][last]
        source = "range-by-range EKF" + (" + RTS" if smooth else "")
        out[pid] = Trajectory(pid, t[last], enu, sigma_enu_m=sig, vel_enu_mps=vel, source=source)
    return out
