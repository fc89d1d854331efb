"""Positioning from anchors on real recordings through ``coopproc run`` (issue 31).

- hanyang_los (a tag, 4 anchors in a 2.6 m cluster, a 50 m path, RTK reference): the best
  UWB-only method's 2-D RMSE <= 0.8 m (the dataset authors' LS: 1.04 m) and no method
  with a mean error above 5 m unflagged;
- miluv1 made a tag (its navigation removed): six anchors ranged one at a time, so almost
  no epoch has three ranges; the UWB-only methods cover >= 90 % of the flight with a
  horizontal RMSE <= 0.3 m;
- tuc, plain: the robot (a follower with wheel odometry) also gets lsq / lsq_rts rows.

Each session is run once (module-scoped fixtures); skipped without ../shared.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io.session import read_session
from coopproc.run.implausible import implausible_methods
from coopproc.stages.base import PositionProduct
from coopproc.stages.shared.lsq import LsqParams, robust_lsq_positions

pytestmark = pytest.mark.slow  # real-session runs: CI runs them after the README command

REAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real"
UWB_ONLY = ("lsq", "lsq_rts", "range_rts")


def _real(name: str) -> Path:
    path = REAL / name
    if not (path / "session.toml").is_file():
        pytest.skip("shared/data/real is not present")
    return path


def _run(session: Path, out: Path) -> str:
    res = CliRunner().invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    return res.output


def _metrics(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / "position_metrics.csv").set_index(["platform", "method"])


@pytest.fixture(scope="module")
def hanyang(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    session = _real("hanyang_los")
    out = tmp_path_factory.mktemp("hanyang") / "out"
    return out, _run(session, out)


def test_hanyang_best_uwb_only_beats_the_authors(hanyang: tuple[Path, str]) -> None:
    out, output = hanyang
    m = _metrics(out).loc["tag"]
    assert set(UWB_ONLY) <= set(m.index)
    assert m.loc[list(UWB_ONLY), "rmse"].min() <= 0.8  # measured lsq_rts 0.626 m
    assert m.loc["range_rts", "rmse"] <= 0.8  # measured 0.664 m
    flagged = json.loads((out / "run.json").read_text())["summary"].get("implausible", {})
    assert all(m.loc[k, "mean"] <= 5.0 or k in flagged for k in m.index)  # lsq: 0.56 m
    assert "estimated from" in output and "height 1.02 m" in output  # never a silent 0 m
    quality = pd.read_csv(out / "lsq_quality.csv")
    assert set(quality["status"]) <= {"ok", "dop", "residual", "mirror", "diverged"}
    ok = quality["status"] == "ok"
    assert ok.sum() == m.loc["lsq", "n"] + 2  # 2 fixes before the reference starts
    assert quality.loc[ok, "hdop"].max() <= 50.0


def test_hanyang_old_solver_is_flagged_as_implausible() -> None:
    """The pre-issue-31 per-epoch solver (still the fusion's start fix) flips to the
    mirror: 10^6 m fixes, which run/implausible.py names."""
    session = read_session(_real("hanyang_los"))
    old = robust_lsq_positions(session, session.ranges.frame, LsqParams())
    flags = implausible_methods(session, {"lsq": PositionProduct(positions=old)})
    assert flags["lsq"]["tag"]["jumps"] > 10  # measured 63 of 758 epochs


@pytest.fixture(scope="module")
def miluv_tag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    source = _real("miluv1")
    root = tmp_path_factory.mktemp("miluv")
    copy = root / "miluv-tag"
    shutil.copytree(source, copy)
    for path in copy.rglob("*"):
        path.chmod(0o644 if path.is_file() else 0o755)
    (copy / "nav_ifo001.csv").unlink()
    toml = copy / "session.toml"
    toml.write_text(toml.read_text().replace('role = "follower"', 'role = "tag"'))
    _run(copy, root / "out")
    return copy, root / "out"


def test_miluv_as_a_tag_is_covered_with_staggered_ranges(miluv_tag: tuple[Path, Path]) -> None:
    copy, out = miluv_tag
    m = _metrics(out).loc["ifo001"]
    assert m.loc["range_rts", "rmse"] <= 0.3  # measured 0.239 m
    pos = pd.read_csv(out / "positions.csv")
    t = np.sort(pos.loc[pos["method"] == "range_rts", "time"].to_numpy())
    ref = read_session(copy).reference["ifo001"].time_s
    near = np.abs(t[np.clip(np.searchsorted(t, ref), 0, len(t) - 1)] - ref) <= 1.0
    assert near.mean() >= 0.9  # measured: every reference epoch within 1 s of a row


def test_tuc_plain_run_has_the_uwb_only_rows(tmp_path: Path) -> None:
    out = tmp_path / "out"
    output = _run(_real("tuc"), out)
    assert "UWB-only lsq, lsq_rts added to [pipeline] positions as comparison rows" in output
    m = _metrics(out).loc["robot"]
    assert m.loc["lsq", "rmse"] < 0.24 and m.loc["lsq_rts", "rmse"] < 0.19  # 0.220, 0.172
    assert m.loc["observed", "rmse"] == pytest.approx(0.1736, abs=1e-4)  # untouched
