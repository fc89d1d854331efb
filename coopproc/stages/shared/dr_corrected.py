"""Dead-reckoning displacements corrected by the fusion's DR states, for the DR DI and the
cooperative solution of ``[fusion] cp_state = "corrected"``.

The DR DI of paper 000 (eq. (1), :func:`~coopproc.stages.ranging.di.anchored_increments`)
takes each platform's own navigation displacement between range epochs. A follower's
dead reckoning rotates its steps by a heading error that grows with time (a gyro bias
of 2-3 deg/h is 5 deg after 2 h) and scales them by its odometer error, so the DR DI of
a pair errs by about theta x the relative speed across the line of sight, more and more
as the heading error grows (real MiLUV: the fusion finds the drone up to 12.7 deg off;
with the correction its DI RMSE / observed falls from 0.54 to 0.44, median over pairs,
docs/methods-ranging.md). On the 2 h paper-experiment sessions, whose followers drift
a few degrees, the DI's RMSE still grows over the recording with it (about 2 % lower):
that growth has another cause.

The cooperative fusion with ``[fusion] state = "dr"`` estimates each follower's heading
correction theta and scale correction s (:mod:`coopproc.estimation.dr_model`:
the true increment is (1 + s) R(theta) u). :func:`corrected_navigation` applies them to
the navigation's increments, east/north (up unchanged), and integrates from the first
epoch: the corrected track's displacements are what the DR DI takes (its accumulated
position does not matter: the DR DI is anchored at the cooperative positions). The
states are slow (random walks of deg/sqrt(h) and ppm), so the pair's own ranges move
them little over an NLOS event; they come from dr_states.csv's table (its convention:
heading error theta in deg, scale error -s / (1 + s)).

With ``[fusion] cp_state = "corrected"`` the ranging stage's cooperative solution is paper
000's position-state fusion of the navigation corrected here (:func:`corrected_session`,
by the causal filter's states): there the accumulated track matters, and a follower's
position no longer walks away with its heading error over a long recording.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from coopproc.model import Session, Trajectory
from coopproc.names import pair_members

__all__ = ["corrected_by_others", "corrected_navigation", "corrected_session", "judged_by_others"]


def corrected_navigation(traj: Trajectory, states: pd.DataFrame) -> Trajectory:
    """``traj`` with its east/north increments rotated and scaled by ``states`` (one
    platform's rows of dr_states.csv, by time), taken at each increment's middle time
    (linear interpolation, held at the ends). Its velocity columns are kept as recorded:
    the RN-Based reference method reads them (paper 000's method, uncorrected), the DR DI
    reads the corrected positions."""
    t = traj.time_s
    if t.shape[0] < 2 or len(states) == 0:
        return traj
    st = states["time"].to_numpy(np.float64)
    theta_deg = states["heading_error"].to_numpy(np.float64)
    scale_err = states["scale_error"].to_numpy(np.float64)
    mid = 0.5 * (t[1:] + t[:-1])
    theta = np.radians(np.interp(mid, st, theta_deg))
    gain = 1.0 / (1.0 + np.interp(mid, st, scale_err))  # (1 + s) = 1 / (1 + scale_error)
    d = np.diff(traj.enu_m, axis=0)
    c, s = np.cos(theta), np.sin(theta)
    de = gain * (c * d[:, 0] - s * d[:, 1])
    dn = gain * (s * d[:, 0] + c * d[:, 1])
    enu = traj.enu_m.copy()
    enu[1:, 0] = enu[0, 0] + np.cumsum(de)
    enu[1:, 1] = enu[0, 1] + np.cumsum(dn)
    return replace(traj, enu_m=enu)


def corrected_session(session: Session, states: pd.DataFrame | None) -> Session:
    """``session`` with each platform's navigation that ``states`` (dr_states.csv's table:
    the followers') has rows for corrected by :func:`corrected_navigation`; the others,
    and every other part of the session, as they are. The fusion's ``cp_state =
    "corrected"`` solution fuses it (docs/methods-ranging.md#cp-state)."""
    if states is None or len(states) == 0:
        return session
    nav = dict(session.nav)
    for platform, rows in states.groupby("platform", sort=True):
        if str(platform) in nav:
            nav[str(platform)] = corrected_navigation(nav[str(platform)], rows)
    return replace(session, nav=nav)


def judged_by_others(session: Session) -> frozenset[str]:
    """The platforms whose DR states more than one pair's ranges estimate: those ranging
    with two or more partners (platforms or anchors). A follower with one partner has
    DR states fitted to that pair's ranges alone, so correcting that pair's DR DI by them
    would judge the pair with itself (the brief's self-calibration rule): on
    ``paper-table1`` (one pair, 10 Hz, NLOS 0.26 m RMSE) its heading-rate state reaches
    -145 deg/h against a 2.2 deg/h gyro bias, and the corrected DR DI tripled DI's RMSE
    (0.022 -> 0.061 m)."""
    partners: dict[str, set[str]] = {}
    for pair in session.ranges.pairs:
        a, b = pair_members(pair)
        partners.setdefault(a, set()).add(b)
        partners.setdefault(b, set()).add(a)
    return frozenset(p for p, others in partners.items() if len(others) >= 2)


def corrected_by_others(session: Session, states: pd.DataFrame) -> Session:
    """:func:`corrected_session` by the states of the platforms that
    :func:`judged_by_others` names only: what the DR DI and the ``corrected`` CP solution
    take."""
    return corrected_session(session, states[states["platform"].isin(judged_by_others(session))])
