"""Issue 29, deliverable 4: coverage per platform, not per session, through `coopproc run`.

One platform's navigation shorter than the ranges (cut at the end, or starting late):
the other platforms are still fused, reported and scored over their own navigation, to
the session's end, and the short one inside its own span only. The simulator's
``nav-gaps`` scenario (C's navigation ends 60 s early) keeps the A-B distance increments
of the cooperative solution to the end.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from tests.e2e.conftest import E2ERun

#: C's navigation kept inside this span, s from the session start (120 s of ranges)
CUTS = {"ends-early": (0.0, 80.0), "starts-late": (40.0, 200.0)}


def _run(session: Path, out: Path) -> None:
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A 120 s paper-experiment session with full navigation, and its run."""
    root = tmp_path_factory.mktemp("nav-span")
    session, out = root / "full", root / "full-out"
    args = ["simulate", str(session), "--scenario", "paper-experiment", "--duration", "120"]
    res = CliRunner().invoke(main, [*args, "--seed", "0"])
    assert res.exit_code == 0, res.output
    _run(session, out)
    return session, out


def _cut_run(full: tuple[Path, Path], root: Path, cut: str) -> tuple[Path, Path, float, float]:
    """The session with C's navigation inside ``CUTS[cut]`` only, its run, and that span."""
    session = root / cut
    shutil.copytree(full[0], session)
    nav = pd.read_csv(session / "nav_C.csv")
    t0 = float(nav["time"].iloc[0])
    lo, hi = (t0 + s for s in CUTS[cut])
    nav = nav[(nav["time"] >= lo) & (nav["time"] <= hi)]
    nav.to_csv(session / "nav_C.csv", index=False, float_format="%.6f")
    out = root / f"{cut}-out"
    _run(session, out)
    return session, out, float(nav["time"].iloc[0]), float(nav["time"].iloc[-1])


def _times(positions: pd.DataFrame, platform: str, method: str) -> np.ndarray:
    rows = positions[(positions["platform"] == platform) & (positions["method"] == method)]
    return rows["time"].to_numpy()


def _n(out: Path, platform: str, method: str) -> int:
    m = pd.read_csv(out / "position_metrics.csv")
    return int(m[(m["platform"] == platform) & (m["method"] == method)]["n"].iloc[0])


@pytest.mark.parametrize("cut", sorted(CUTS))
def test_one_shorter_navigation_leaves_the_others_whole(
    full: tuple[Path, Path], tmp_path: Path, cut: str
) -> None:
    session, out, c_first, c_last = _cut_run(full, tmp_path, cut)
    whole = pd.read_csv(full[1] / "positions.csv")
    mine = pd.read_csv(out / "positions.csv")
    ranges = pd.read_csv(session / "ranges.csv")
    t = ranges["time"].to_numpy()
    with_c = ((ranges["from"] == "C") | (ranges["to"] == "C")).to_numpy()
    covered = ~with_c | ((t >= c_first) & (t <= c_last))  # what coopproc run keeps
    for platform in "AB":
        of = ((ranges["from"] == platform) | (ranges["to"] == platform)).to_numpy()
        own = np.unique(t[of & covered])  # its range epochs with both ends navigating
        for method in ("nav", "observed", "di"):
            got = _times(mine, platform, method)
            # at every epoch of its ranges that both ends navigate, to the session's end
            # (its last A-B range: within the 1 s ranging interval of its last range)
            assert np.array_equal(got, own), (platform, method)
            assert got.max() > _times(whole, platform, method).max() - 1.0
        # Table 3: its n is the full-navigation run's at those epochs (own nav included)
        scored = whole[(whole["platform"] == platform) & (whole["method"] == "observed")]
        want = int((np.isin(scored["time"], own) & scored["error_h"].notna()).sum())
        # the common span's cut gave only those inside C's navigation; now its A-B epochs
        # outside it count too (one a second over 40 s, less reference gaps)
        common = int(scored["time"].between(c_first, c_last).sum())
        assert want > common + 20
        for method in ("nav", "observed", "rn", "di"):
            assert _n(out, platform, method) == want, (platform, method)
    # C only inside its own navigation
    for method in ("nav", "observed", "rn", "di", "reference"):
        got = _times(mine, "C", method)
        assert got.min() >= c_first and got.max() <= c_last, method
    res = CliRunner().invoke(main, ["report", str(out), "--table"])
    assert res.exit_code == 0 and "Table 3" in res.output, res.output


def test_nav_gaps_keeps_the_cooperative_increments_of_the_others(
    e2e_runs: Callable[[str, int], E2ERun],
) -> None:
    run = e2e_runs("nav-gaps", 0)
    di = pd.read_csv(run.out / "di.csv")
    nav_c = pd.read_csv(run.session / "nav_C.csv")
    start = float(di["time"].min())
    c_last = float(nav_c["time"].iloc[-1])
    assert c_last - start < 540.0  # C's navigation ends 60 s before the ranges
    ab = di[(di["pair"] == "A-B") & (di["time"] > c_last)]
    assert len(ab) > 50
    for column in ("di_cp", "di_smoothed"):
        assert ab[column].notna().all(), column
    positions = pd.read_csv(run.out / "positions.csv")
    for platform in "AB":
        assert _times(positions, platform, "observed").max() - start > 598.0
    assert _times(positions, "C", "observed").max() <= c_last


def test_nav_gaps_are_recorded_and_shaded_as_such(
    e2e_runs: Callable[[str, int], E2ERun],
) -> None:
    """run.json ``nav_gaps`` from the session before its samples are let go of; the figures
    shade those stretches as "Navigation gap", not as a UWB outage (issue 32.8)."""
    import json

    from coopproc.report.figures import distance_errors_figure, position_errors_figure
    from coopproc.report.gaps import shaded_spans
    from coopproc.report.rundir import load_run

    run = e2e_runs("nav-gaps", 0)
    info = json.loads((run.out / "run.json").read_text())
    nav = {p: pd.read_csv(run.session / f"nav_{p}.csv")["time"].to_numpy() for p in "AC"}
    t0 = float(min(nav["A"][0], run.ranges["time"].min()))
    gaps = info["nav_gaps"]
    assert sorted(gaps) == ["A", "C"]  # B (the leader) has none
    (a_gap,) = gaps["A"]  # nav_A.csv has no rows at 270-330 s (5 Hz: 269.9 and 330.1 kept)
    assert np.allclose(np.subtract(a_gap, t0), [269.9, 330.1], atol=1e-6)
    (c_end,) = gaps["C"]  # nav_C.csv ends at 539.9 s, the run at 600 s
    assert c_end[0] == pytest.approx(float(nav["C"][-1]), abs=1e-6)
    assert c_end[1] - t0 == pytest.approx(600.0, abs=0.05)
    loaded = load_run(run.out)
    origin = loaded.time_origin_s
    positions = position_errors_figure(loaded)
    distances = distance_errors_figure(loaded)
    assert positions is not None and distances is not None
    a, b, c = positions.axes  # platforms A, B, C
    assert np.allclose(shaded_spans(a, "nav_gap"), np.subtract([a_gap], origin), atol=0.3)
    assert shaded_spans(a, "uwb_outage").size == 0
    assert shaded_spans(b, "nav_gap").size == 0 and shaded_spans(b, "uwb_outage").size == 0
    # to the end of the drawn data (the positions' last epoch, 599 s: at range epochs)
    ((c_from, c_to),) = shaded_spans(c, "nav_gap")
    assert c_from == pytest.approx(c_end[0] - origin, abs=0.3) and 598.5 < c_to <= c_end[1] - origin
    ab, ac, bc = distances.axes  # A-B: A's gap only; A-C: both; B-C: C's end
    assert np.allclose(shaded_spans(ab, "nav_gap"), np.subtract([a_gap], origin), atol=1.5)
    assert shaded_spans(ac, "nav_gap").shape == (2, 2)
    ((bc_from, bc_to),) = shaded_spans(bc, "nav_gap")
    assert bc_from == pytest.approx(c_end[0] - origin, abs=1.5) and bc_to > 598.5
    for ax in (*positions.axes, *distances.axes):
        assert shaded_spans(ax, "uwb_outage").size == 0  # nothing called an outage
    labels = [t.get_text() for legend in distances.legends for t in legend.get_texts()]
    assert "Navigation gap" in labels and "UWB outage" not in labels
