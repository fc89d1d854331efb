"""Small sessions with known content for the io tests (written with the writers)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.model import Platform, RangeTable, Session, SessionConfig, Trajectory, pair_name

ORIGIN = (34.7980, 113.6590, 110.0)
WEEK = 2178
T0 = 432000.0  # gps_tow


def make_session(
    *,
    n_nav: int = 50,
    time_base: str = "gps_tow",
    extras: bool = True,
    rich: bool = True,
) -> Session:
    """Three platforms (A follower, B leader, C follower) + anchor X, 10 Hz nav, 1 Hz ranges."""
    rng = np.random.default_rng(7)
    t0 = T0 if time_base == "gps_tow" else (1_633_075_200.0 if time_base == "unix" else 0.0)
    t = t0 + np.arange(n_nav) * 0.1
    nav, ref = {}, {}
    for k, pid in enumerate(("A", "B", "C")):
        enu = np.column_stack(
            [0.5 * (t - t0) + 5 * k, 2.0 * k + np.sin(t - t0), np.full(t.size, 0.1 * k)]
        )
        nav[pid] = Trajectory(
            pid,
            t.copy(),
            enu + rng.normal(0, 0.05, enu.shape),
            sigma_enu_m=np.full((t.size, 3), 0.05) if rich else None,
            vel_enu_mps=np.tile([0.5, 0.0, 0.0], (t.size, 1)) if rich else None,
            heading_deg=np.full(t.size, 90.0 + k) if rich else None,
        )
        ref[pid] = Trajectory(
            pid,
            t.copy(),
            enu,
            sigma_enu_m=np.full((t.size, 3), 0.01),
            quality=np.ones(t.size, dtype=np.int64),
        )
    tr = t[::10]
    rows = []
    for a, b in (("A", "B"), ("B", "C"), ("A", "C"), ("C", "X")):
        for i, ti in enumerate(tr):
            src, dst = (a, b) if i % 2 == 0 else (b, a)
            rows.append((ti, pair_name(a, b), src, dst, 5.0 + i, 0.1 if i % 3 else np.nan))
    frame = pd.DataFrame(rows, columns=["time", "pair", "from", "to", "range", "sigma"])
    frame = frame.sort_values("time", kind="stable").reset_index(drop=True)
    if extras:
        frame["rssi"] = np.round(-80.0 + np.arange(len(frame)) * 0.5, 3)
    platforms = {
        "A": Platform("A", "follower", 0.02),
        "B": Platform("B", "leader"),
        "C": Platform("C", "follower"),
        "X": Platform("X", "anchor", None, (1.0, 2.0, 3.0)),
    }
    config = SessionConfig(
        name="unit",
        time_base=time_base,  # type: ignore[arg-type]
        gps_week=WEEK if time_base == "gps_tow" else None,
        origin_llh=ORIGIN,
        platforms=platforms,
        uwb_sigma_m=0.15,
    )
    return Session(
        config=config,
        platforms=platforms,
        nav=nav,
        reference=ref,
        ranges=RangeTable(frame),
        origin_llh=ORIGIN,
        root=Path("."),
    )


def assert_same_session(
    a: Session, b: Session, *, pos_tol: float = 2e-4, rich: bool = True
) -> None:
    """The model content is the same within float formatting precision."""
    assert sorted(a.nav) == sorted(b.nav)
    assert sorted(a.reference) == sorted(b.reference)
    assert dict(a.platforms) == dict(b.platforms)
    assert np.allclose(a.origin_llh, b.origin_llh, atol=1e-9)
    assert a.config.time_base == b.config.time_base
    for group_a, group_b in ((a.nav, b.nav), (a.reference, b.reference)):
        for pid in group_a:
            ta, tb = group_a[pid], group_b[pid]
            np.testing.assert_allclose(ta.time_s, tb.time_s, atol=1e-6, rtol=0)
            np.testing.assert_allclose(ta.enu_m, tb.enu_m, atol=pos_tol, rtol=0)
            if rich and ta.sigma_enu_m is not None:
                assert tb.sigma_enu_m is not None
                np.testing.assert_allclose(ta.sigma_enu_m, tb.sigma_enu_m, atol=1e-4)
    fa, fb = a.ranges.frame, b.ranges.frame
    assert list(fa["pair"]) == list(fb["pair"])
    assert list(fa["from"]) == list(fb["from"])
    np.testing.assert_allclose(fa["time"], fb["time"], atol=1e-6)
    np.testing.assert_allclose(fa["range"], fb["range"], atol=1e-6)
    np.testing.assert_allclose(fa["sigma"], fb["sigma"], atol=1e-6)  # NaN == NaN here


@pytest.fixture
def session_factory() -> Callable[..., Session]:
    return make_session


@pytest.fixture
def sample_dir(tmp_path: Path) -> Path:
    from coopproc.io import write_session

    write_session(make_session(), tmp_path / "s")
    return tmp_path / "s"


class Kit:
    """The helpers above, for test modules (importlib mode cannot import conftest)."""

    ORIGIN = ORIGIN
    WEEK = WEEK
    T0 = T0
    make_session = staticmethod(make_session)
    assert_same_session = staticmethod(assert_same_session)


@pytest.fixture
def kit() -> type[Kit]:
    return Kit
