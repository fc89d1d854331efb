"""Issue 17, item 4: ``coopproc locate`` on real recordings (skipped without
``../shared/data/real``).

- TIERS (case 4, test 3): a multi-robot case built from the shared session: the target
  tb3 keeps its navigation (the mocap trajectory with wheel-odometry-like drift: 1-3 %
  scale, 2-5 deg/min heading), the other robots' navigation becomes their mocap
  reference (auxiliaries with good positions, as GNSS would give), the parked tb1/tb2
  stay anchors. tb4 is body-blocked (NLOS up to 2 m on its pairs): the faulty one.
- TUC labyrinth: the robot's real wheel-odometry dead reckoning as the target, the four
  fixed UWB modules (anchors, no navigation: their surveyed position) as auxiliaries.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main

REAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real"

#: Process noise for wheel odometry (paper 004's INS/odometer defaults are far tighter).
WHEEL = """
[locate]
N = 100
M = 100
methods = {methods}
step_sigma_m = {step}
step_sigma_rel = {step}
heading_sigma_deg = {heading}
odometer_scale_sigma = {scale}
"""


def _real(name: str) -> Path:
    path = REAL / name
    if not (path / "session.toml").exists():
        pytest.skip("shared/data/real is not present")
    return path


def tiers_case(root: Path, target: str = "tb3") -> Path:
    """The TIERS session with every robot but ``target`` navigating on its mocap track."""
    case = root / f"tiers_{target}"
    shutil.copytree(_real("tiers"), case)
    for ref in sorted(case.glob("ref_*.csv")):
        pid = ref.stem[4:]
        if pid != target:
            pd.read_csv(ref).to_csv(case / f"nav_{pid}.csv", index=False)
    return case


def _locate(session: Path, target: str, aux: str, config: str, out: Path) -> str:
    cfg = out.parent / f"{out.name}.toml"
    cfg.write_text(config, encoding="utf-8")
    result = CliRunner().invoke(
        main,
        ["locate", str(session), "--target", target, "--aux", aux, "-o", str(out),
         "--config", str(cfg), "--no-figures"],
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    return result.stderr


def _late(out: Path, method: str, seconds: float) -> float:
    table = pd.read_csv(out / "locate.csv")
    rows = table[table["method"] == method]
    t = rows["time"].to_numpy()
    return float(np.mean(rows["error_h"].to_numpy()[t > t[-1] - seconds]))


@pytest.mark.slow
def test_tiers_multi_robot_with_a_body_blocked_auxiliary(tmp_path: Path) -> None:
    case = tiers_case(tmp_path)
    config = WHEEL.format(methods="['aacopf']", step=0.02, heading=0.2, scale=0.02)
    out = tmp_path / "out"
    err = _locate(case, "tb3", "tb4,tb5,tb6,tb7,tb1,tb2", config, out)
    summary = pd.read_csv(out / "locate_summary.csv").set_index("method")
    # measured 0.11 m over the last 20 s and +0.5 deg at 200 x 200 (docs/locate.md)
    assert _late(out, "aacopf", 20.0) < 0.3
    assert abs(summary.loc["aacopf", "azimuth_error"]) < 2.0
    assert summary.loc["aacopf", "unique"] == 1
    assert "'tb5' rejected" not in err


def test_tuc_wheel_odometry_with_fixed_modules(tmp_path: Path) -> None:
    config = WHEEL.format(methods="['aacopf', 'ekf']", step=0.04, heading=2.0, scale=0.05)
    outs = {}
    for warmup in ("first", "quiet"):
        outs[warmup] = tmp_path / warmup
        _locate(
            _real("tuc"), "robot", "u105,u107,u108,u109",
            config + f'warmup = "{warmup}"\n', outs[warmup],
        )  # fmt: skip
    summary = pd.read_csv(outs["first"] / "locate_summary.csv").set_index("method")
    assert list(summary.index) == ["aacopf", "ekf"]
    # a 2.4 m labyrinth, 30 s, wheel odometry drifting 0.25 m/s: the EKF bank stays
    # within about half a metre at the end; the AACOPF only with warmup = "quiet" (the
    # ring's fixed module alone never makes the cloud converge; docs/locate.md)
    assert _late(outs["first"], "ekf", 10.0) < 0.6
    assert _late(outs["quiet"], "aacopf", 10.0) < 0.8
