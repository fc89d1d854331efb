"""positions.csv built in place (coopproc.run.positions_table) against the plain build:
one frame per platform and method, concatenated and sorted."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coopproc.io import read_session
from coopproc.io.outdir import csv_text
from coopproc.model import POSITIONS_COLUMNS, Session, Trajectory
from coopproc.run.positions_table import (
    PositionSamples,
    _missing_rows,
    own_epochs,
    positions_table,
)
from coopproc.stages.base import PositionProduct

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"


@pytest.fixture(scope="module")
def session() -> Session:
    return read_session(SAMPLE)


def _solution(
    session: Session, shift_m: float, shuffle: str | None = None
) -> dict[str, Trajectory]:
    """Each platform's nav shifted east by ``shift_m``, at every range time; the platform
    ``shuffle`` with its epochs out of time order."""
    times = np.unique(session.ranges.frame["time"].to_numpy(np.float64))
    out = {}
    for platform, nav in session.nav.items():
        t = times.copy()
        if platform == shuffle:
            t = t[np.random.default_rng(1).permutation(len(t))]
        enu = nav.interpolate(t) + np.array([shift_m, 0.0, 0.0])
        out[platform] = Trajectory(platform, t, enu)
    return out


def _plain(session: Session, products: dict[str, PositionProduct]) -> pd.DataFrame:
    """The table as it was built before: frames per (platform, method), sorted."""
    own = own_epochs(session)
    frames = []

    def rows(platform: str, method: str, t: np.ndarray, enu: np.ndarray, ref: bool) -> None:
        truth = session.reference[platform].interpolate_within(t)
        if ref:
            ok = np.all(np.isfinite(truth), axis=1)
            t, enu, err = t[ok], truth[ok], np.full(int(ok.sum()), np.nan)
        else:
            err = np.hypot(enu[:, 0] - truth[:, 0], enu[:, 1] - truth[:, 1])
        frames.append(
            pd.DataFrame(
                {"time": t, "platform": platform, "method": method, "east": enu[:, 0]}
                | {"north": enu[:, 1], "up": enu[:, 2], "error_h": err}
            )
        )

    for method, product in products.items():
        for platform, traj in product.positions.items():
            keep = np.isin(traj.time_s, own[platform])
            t, enu = traj.time_s[keep], traj.enu_m[keep]
            rows(platform, method, t, enu, ref=False)
            if method == "observed":
                rows(platform, "reference", t, enu, ref=True)
                rows(platform, "nav", t, session.nav[platform].interpolate(t), ref=False)
    table = pd.concat(frames, ignore_index=True)
    table = table.sort_values(["platform", "method", "time"], kind="stable")
    return table.reset_index(drop=True)[list(POSITIONS_COLUMNS)]


def test_in_place_table_is_the_plain_one_with_compact_text(session: Session) -> None:
    products = {
        "observed": PositionProduct(positions=_solution(session, 0.1)),
        "di": PositionProduct(positions=_solution(session, -0.2, shuffle="B")),
    }
    table = positions_table(session, products, "ranges")
    plain = _plain(session, products)
    assert list(table.columns) == list(POSITIONS_COLUMNS)
    assert len(table) == len(plain) > 0
    assert set(table["method"]) == {"reference", "nav", "observed", "di"}
    pd.testing.assert_frame_equal(
        table.astype({"platform": str, "method": str}), plain, check_exact=True
    )
    assert csv_text(table) == csv_text(plain)  # the same bytes in positions.csv
    for column in ("platform", "method"):  # one byte per row, not a string per row
        assert isinstance(table[column].dtype, pd.CategoricalDtype)
        assert table[column].cat.codes.dtype == np.int8
    # the out-of-order solution comes out in time order
    rows = table[(table["platform"] == "B") & (table["method"] == "di")]
    assert rows["time"].is_monotonic_increasing and len(rows)


def test_no_positions_gives_the_empty_table(session: Session) -> None:
    table = positions_table(session, {"observed": PositionProduct(positions={})}, "ranges")
    assert list(table.columns) == list(POSITIONS_COLUMNS)
    assert len(table) == 0


def test_release_empties_the_solutions_and_gives_the_same_table(session: Session) -> None:
    def products() -> dict[str, PositionProduct]:
        return {
            "observed": PositionProduct(positions=_solution(session, 0.1)),
            "rn": PositionProduct(positions=_solution(session, 0.3)),
        }

    kept = positions_table(session, products(), "ranges")
    given = products()
    released = positions_table(session, given, "ranges", release=True)
    pd.testing.assert_frame_equal(released, kept, check_exact=True)
    assert all(not p.positions for p in given.values())  # trajectories handed over


def test_release_empties_the_samples_given_and_leaves_the_session(session: Session) -> None:
    def products() -> dict[str, PositionProduct]:
        return {"observed": PositionProduct(positions=_solution(session, 0.1))}

    kept = positions_table(session, products(), "ranges")
    samples = PositionSamples.of(session, "ranges")
    assert set(samples.nav) == set(session.nav) and samples.own is not None
    released = positions_table(samples, products(), "ranges", release=True)
    pd.testing.assert_frame_equal(released, kept, check_exact=True)
    # each platform's navigation and reference went once its rows were written; the
    # session's own dicts are not touched
    assert samples.nav == {} and samples.reference == {}
    assert session.nav and session.reference


def test_own_epochs_are_the_unique_times_of_each_platforms_ranges(session: Session) -> None:
    frame = session.ranges.frame
    own = own_epochs(session)
    assert set(own) == set(session.platform_ids)
    for platform, times in own.items():
        mine = (frame["from"] == platform) | (frame["to"] == platform)
        expected = np.unique(frame["time"].to_numpy(np.float64)[mine.to_numpy()])
        np.testing.assert_array_equal(times, expected)
        assert len(times)


def test_missing_rows_by_merge_are_those_not_in_the_own_epochs() -> None:
    rng = np.random.default_rng(4)
    own = np.unique(np.round(rng.uniform(0.0, 50.0, 300), 1))
    times = np.unique(np.concatenate([own[::2], np.round(rng.uniform(-5.0, 60.0, 80), 2)]))
    for t in (times, times[::-1], np.array([own[3]])):  # merged, searched, one epoch
        np.testing.assert_array_equal(_missing_rows(t, own), np.flatnonzero(~np.isin(t, own)))
    assert _missing_rows(times, own).shape[0] > 0


def test_methods_sharing_a_solution_give_the_rows_of_copies(session: Session) -> None:
    # a processed set that reused the observed fusion holds the same trajectories: its
    # rows are made once and taken again, the same as rows made from a copy
    observed = _solution(session, 0.3, shuffle=next(iter(session.nav)))
    copies = {p: Trajectory(p, t.time_s.copy(), t.enu_m.copy()) for p, t in observed.items()}
    shared = {
        "observed": PositionProduct(positions=dict(observed)),
        "rn": PositionProduct(positions=dict(observed)),
        "di": PositionProduct(positions=_solution(session, -0.2)),
    }
    copied = {
        "observed": PositionProduct(positions=dict(observed)),
        "rn": PositionProduct(positions=copies),
        "di": PositionProduct(positions=_solution(session, -0.2)),
    }
    table = positions_table(session, shared, "ranges", release=True)
    pd.testing.assert_frame_equal(table, positions_table(session, copied, "ranges"))
    assert set(table["method"].unique()) == {"observed", "rn", "di", "nav", "reference"}
    assert not shared["rn"].positions  # released as the copies would be
