"""``[ranging.di] dr_states = true``: the DR DI from the navigation corrected by the causal
fusion's heading and scale states (shared/dr_corrected.py), on the real MiLUV session,
whose drone's dead reckoning the fusion finds up to 12.7 deg off."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io import read_session
from coopproc.stages.shared.dr_corrected import judged_by_others
from tests.e2e.conftest import E2ERun

REAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real"


def _run(session: Path, out: Path, config: Path | None) -> tuple[pd.Series, pd.Series]:
    args = ["run", str(session), "-o", str(out), "--no-figures"]
    if config is not None:
        args += ["--config", str(config)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    metrics = pd.read_csv(out / "metrics.csv").set_index(["pair", "method"])["rmse"]
    pm = pd.read_csv(out / "position_metrics.csv").set_index(["platform", "method"])["mean"]
    return metrics, pm


@pytest.mark.slow  # two runs of a real session
def test_corrected_dr_di_on_real_miluv(tmp_path: Path) -> None:
    session = REAL / "miluv1"
    if not session.is_dir():
        pytest.skip(f"no shared real session {session}")
    config = tmp_path / "on.toml"
    config.write_text("[ranging.di]\ndr_states = true\n", encoding="utf-8")
    off = tmp_path / "off.toml"  # the same CP solution, the DR DI as recorded
    off.write_text("[ranging.di]\ndr_states = false\n", encoding="utf-8")
    plain, plain_pm = _run(session, tmp_path / "plain", off)
    fixed, fixed_pm = _run(session, tmp_path / "fixed", config)
    pairs = sorted({p for p, m in fixed.index if m == "di"})
    assert len(pairs) == 6
    # measured: DI RMSE / observed 0.54 -> 0.44 (median over the six anchor pairs)
    plain_ratio = pd.Series({p: plain[(p, "di")] / plain[(p, "observed")] for p in pairs})
    fixed_ratio = pd.Series({p: fixed[(p, "di")] / fixed[(p, "observed")] for p in pairs})
    assert fixed_ratio.median() < 0.9 * plain_ratio.median()
    assert (fixed_ratio < 1.0).all()
    # DI-fused against observed-fused (issue 29.3 asks <= 1.1 x): 1.006 x with the
    # defaults, 1.125 x with the DR DI as recorded (1.09 x with paper 000's CP too)
    assert fixed_pm[("ifo001", "di")] <= 1.05 * fixed_pm[("ifo001", "observed")]
    assert fixed_pm[("ifo001", "observed")] == plain_pm[("ifo001", "observed")]


def test_a_follower_with_one_partner_is_not_corrected_by_its_pair(
    e2e_runs: Callable[[str, int], E2ERun], tmp_path: Path
) -> None:
    """paper-table1: one follower, one pair. Its DR states are fitted to that pair's
    ranges alone (heading rate -145 deg/h against a 2.2 deg/h gyro bias), so the DR DI
    keeps its recorded navigation: with the correction DI's RMSE went 0.022 -> 0.061 m."""
    plain = e2e_runs("paper-table1", 0)
    assert judged_by_others(read_session(plain.session)) == frozenset()
    config = tmp_path / "on.toml"
    config.write_text("[ranging.di]\ndr_states = true\n", encoding="utf-8")
    fixed, _ = _run(plain.session, tmp_path / "fixed", config)
    pair = "A-B"
    assert fixed[(pair, "di")] == pytest.approx(plain.metric(pair, "di", "rmse"), rel=1e-9)
    assert fixed[(pair, "di")] < 0.2 * fixed[(pair, "observed")]
