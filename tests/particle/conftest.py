"""In-memory single-auxiliary sessions with known truth for the particle tests."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory, pair_name


def make_session(
    seed: int = 1,
    duration_s: float = 150.0,
    aux_motion: str = "moving",
    biased_second: bool = False,
    rotation_deg: float = 40.0,
    sigma_m: float = 0.1,
) -> tuple[Session, np.ndarray]:
    """Target T on a rounded loop, auxiliary A1 moving (or static / same-direction).

    Returns the session (T's nav in a frame rotated by ``rotation_deg`` and shifted) and
    the true initial heading of T in degrees clockwise from north.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s + 1e-9, 0.1)
    # target: 1 m/s on a 30 x 20 m ellipse-like loop starting at (5, -3)
    w = 2 * np.pi / 90.0
    te = 5.0 + 15.0 * np.sin(w * t)
    tn = -3.0 + 10.0 * (1 - np.cos(w * t))
    if aux_motion == "moving":
        ae = 20.0 - 12.0 * np.cos(2 * np.pi * t / 60.0)
        an = 15.0 + 0.15 * t - 6.0 * np.sin(2 * np.pi * t / 45.0)
    elif aux_motion == "static":
        ae = np.full_like(t, 18.0)
        an = np.full_like(t, 12.0)
    else:  # same direction: keeps a constant offset from the target
        ae = te + 12.0
        an = tn + 9.0
    truth = np.column_stack([te, tn, np.zeros_like(t)])
    # DR: rotated + shifted, small heading drift (0.002 deg/s) and 1 % scale error
    steps = np.diff(truth[:, :2], axis=0) * 1.01
    drift = np.radians(0.002) * t[1:]
    rot = np.radians(rotation_deg) + drift
    c, s = np.cos(rot), np.sin(rot)
    own = np.column_stack([c * steps[:, 0] - s * steps[:, 1], s * steps[:, 0] + c * steps[:, 1]])
    start = np.array([100.0, -50.0])
    own = np.vstack([start, start + np.cumsum(own, axis=0)])
    nav_t = Trajectory("T", t, np.column_stack([own, np.zeros_like(t)]))
    aux_true = np.column_stack([ae, an, np.zeros_like(t)])
    nav_a = Trajectory("A1", t, aux_true + rng.normal(0, 0.02, aux_true.shape))
    ref_t = Trajectory("T", t, truth + rng.normal(0, 0.01, truth.shape))
    navs = {"T": nav_t, "A1": nav_a}
    tr = t[::10]
    frames = []
    d = np.hypot(te - ae, tn - an)[::10]
    frames.append(
        pd.DataFrame(
            {
                "time": tr,
                "pair": pair_name("T", "A1"),
                "from": "T",
                "to": "A1",
                "range": d + rng.normal(0, sigma_m, tr.shape),
                "sigma": sigma_m,
            }
        )
    )
    if biased_second:
        be = -10.0 + 0.2 * t
        bn = 25.0 - 8.0 * np.sin(2 * np.pi * t / 70.0)
        b_true = np.column_stack([be, bn, np.zeros_like(t)])
        navs["A2"] = Trajectory("A2", t, b_true + rng.normal(0, 0.02, b_true.shape))
        d2 = np.hypot(te - be, tn - bn)[::10]
        # peak-shift bias plus heavy-tailed (exponential) NLOS-like errors
        err2 = 1.5 + rng.exponential(1.0, tr.shape) + rng.normal(0, sigma_m, tr.shape)
        frames.append(
            pd.DataFrame(
                {
                    "time": tr + 0.5,
                    "pair": pair_name("T", "A2"),
                    "from": "A2",
                    "to": "T",
                    "range": d2[: tr.shape[0]] + err2,
                    "sigma": sigma_m,
                }
            )
        )
    frame = pd.concat(frames, ignore_index=True).sort_values("time", kind="stable")
    frame = frame.reset_index(drop=True)
    platforms = {p: Platform(p, role="follower" if p == "T" else "leader") for p in navs}
    session = Session(
        config=SessionConfig(name="sim-single-aux", time_base="relative", platforms=platforms),
        platforms=platforms,
        nav=navs,
        reference={"T": ref_t},
        ranges=RangeTable(frame),
        origin_llh=(0.0, 0.0, 0.0),
        root=Path("/nonexistent/sim-single-aux"),
    )
    # the direction of the first step between 1 Hz filter epochs
    heading0 = float((90.0 - np.degrees(np.arctan2(tn[10] - tn[0], te[10] - te[0]))) % 360.0)
    return session, np.array([heading0])


@pytest.fixture(scope="session")
def single_aux_session() -> Callable[..., tuple[Session, np.ndarray]]:
    """The :func:`make_session` factory."""
    return make_session
