"""Robust least-squares positioning from anchors (paper 003 section 2.2) against truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory, pair_name
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.shared.lsq import LsqParams, robust_lsq_positions

ANCHORS = {
    "N1": (0.0, 0.0, 2.5),
    "N2": (30.0, 0.0, 2.0),
    "N3": (30.0, 20.0, 2.8),
    "N4": (0.0, 20.0, 2.2),
    "N5": (15.0, 10.0, 3.0),
}


def anchor_session(
    *, seed: int = 2, nlos_m: float = 0.0, duration_s: float = 200.0, dr_offset: float = 0.0
) -> tuple[Session, np.ndarray, np.ndarray, np.ndarray]:
    """Tag T on an ellipse inside five anchors; N1's ranges carry +nlos_m (NLOS)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 0.1)
    w = 2 * np.pi / 100.0
    truth = np.stack([15 + 10 * np.cos(w * t), 10 + 6 * np.sin(w * t), np.full_like(t, 1.0)], 1)
    vel = np.stack([-10 * w * np.sin(w * t), 6 * w * np.cos(w * t), np.zeros_like(t)], 1)
    err = np.cumsum(rng.normal(0, 0.003, truth.shape), axis=0) + np.array([dr_offset, 0.0, 0.0])
    err[:, 2] = 0.0
    platforms = {"T": Platform("T", role="follower", drift_sigma_mps=0.02)}
    for aid, pos in ANCHORS.items():
        platforms[aid] = Platform(aid, role="anchor", position_enu_m=pos)
    epochs = np.arange(1.0, duration_s - 1.0, 1.0)
    idx = np.round(epochs / 0.1).astype(int)
    rows = []
    for aid, pos in ANCHORS.items():
        dist = np.linalg.norm(truth[idx] - np.array(pos), axis=1)
        noise = rng.normal(0, 0.05, epochs.size) + (nlos_m if aid == "N1" else 0.0)
        rows.append(
            pd.DataFrame(
                {
                    "time": epochs,
                    "pair": pair_name("T", aid),
                    "from": "T",
                    "to": aid,
                    "range": dist + noise,
                    "sigma": 0.1,
                }
            )
        )
    frame = pd.concat(rows).sort_values("time", kind="stable").reset_index(drop=True)
    session = Session(
        config=SessionConfig(platforms=platforms),
        platforms=platforms,
        nav={"T": Trajectory("T", t, truth + err)},
        reference={},
        ranges=RangeTable(frame),
        origin_llh=(0.0, 0.0, 0.0),
        root=Path("anchors"),
    )
    return session, truth[idx], vel[idx], epochs


def h_error(traj: Trajectory, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(traj.enu_m[:, :2] - truth[:, :2], axis=1)


def test_clean_fix_and_velocity() -> None:
    session, truth, vel, epochs = anchor_session()
    out = robust_lsq_positions(session, session.ranges.frame, LsqParams())
    traj = out["T"]
    assert traj.time_s == pytest.approx(epochs)
    err = h_error(traj, truth)
    assert err.mean() < 0.06  # 5 cm ranging noise, HDOP ~ 1
    assert traj.sigma_enu_m is not None and np.all(traj.sigma_enu_m[:, :2] < 0.2)
    assert traj.vel_enu_mps is not None
    assert np.isnan(traj.vel_enu_mps[0]).all()  # no range rate at the first epoch
    # rates are means over the previous second: compare with the mid-interval truth
    v_mid = 0.5 * (vel[1:] + vel[:-1])
    v_err = np.linalg.norm(traj.vel_enu_mps[1:, :2] - v_mid[:, :2], axis=1)
    assert np.median(v_err) < 0.12


def test_robust_beats_plain_with_one_nlos_anchor() -> None:
    session, truth, _, _ = anchor_session(nlos_m=1.0)
    plain = robust_lsq_positions(session, session.ranges.frame, LsqParams(robust=False))["T"]
    robust = robust_lsq_positions(session, session.ranges.frame, LsqParams())["T"]
    e_plain = h_error(plain, truth).mean()
    e_robust = h_error(robust, truth).mean()
    assert e_robust < 0.6 * e_plain  # measured: see the report


def test_three_dimensional_fix() -> None:
    session, truth, _, _ = anchor_session()
    traj = robust_lsq_positions(session, session.ranges.frame, LsqParams(dims=3))["T"]
    assert h_error(traj, truth).mean() < 0.1
    assert np.abs(traj.enu_m[:, 2] - truth[:, 2]).mean() < 1.0  # weak vertical geometry


def test_too_few_anchors_gives_no_fix() -> None:
    session, _, _, _ = anchor_session(duration_s=20.0)
    frame = session.ranges.frame
    two = frame[frame["to"].isin(["N1", "N2"])]
    assert robust_lsq_positions(session, two, LsqParams()) == {}


def test_fusion_with_anchors_starts_from_the_lsq_fix() -> None:
    session, truth, _, _ = anchor_session(dr_offset=10.0)
    frame = session.ranges.frame
    started = fuse(session, frame, FusionParams(smoother=False))
    assert h_error(started.forward["T"], truth)[0] < 0.2  # the DR start is 10 m off
    assert h_error(started.smoothed["T"], truth).mean() < 0.1
    cold = fuse(session, frame, FusionParams(smoother=False, init_from_anchors=False))
    # from 10 m off with 1 m assumed, one EKF update does not get there
    assert h_error(cold.forward["T"], truth)[0] > 1.0
