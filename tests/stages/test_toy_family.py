"""docs/extending.md's "A new sensor family", worked end to end without editing coopproc: a
toy estimator ``nav_copy`` (each platform's own navigation, shifted east by its one
parameter) registered the way its registry line would, run through the CLI on the shipped
sample session, and shown by ``coopproc config --session``."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.model import Trajectory
from coopproc.run import config as run_config
from coopproc.stages.base import PositionInput, PositionProduct, PositionStage
from coopproc.stages.registry import POSITION_STAGES

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"


@dataclass(frozen=True)
class NavCopyParams:
    """``[nav_copy]``: the toy family's one parameter."""

    east_m: float = field(default=0.0, metadata={"help": "shift east of the navigation (m)"})


def nav_copy(inp: PositionInput, params: NavCopyParams) -> PositionProduct:
    """Each navigating platform's own navigation, ``east_m`` to the east, at the epochs
    ``inp.output`` asks for: the platform's range epochs (positions.csv keeps a method's
    rows at those only) or the navigation's own."""
    positions = {}
    ranges = inp.ranges
    for platform, nav in inp.session.nav.items():
        time_s = nav.time_s
        if inp.output == "ranges":
            mine = (ranges["from"] == platform) | (ranges["to"] == platform)
            time_s = np.unique(ranges.loc[mine, "time"].to_numpy(dtype=np.float64))
        enu = nav.interpolate(time_s)
        inside = np.all(np.isfinite(enu), axis=1)
        enu[:, 0] += params.east_m
        positions[platform] = Trajectory(platform, time_s[inside], enu[inside])
    return PositionProduct(positions=positions)


NAV_COPY = PositionStage(
    name="nav_copy",
    params_type=NavCopyParams,
    section="nav_copy",
    run=nav_copy,
    help="each platform's own navigation (a toy family, docs/extending.md)",
    requires=frozenset({"navigation"}),
    observed_only=True,
)


@pytest.fixture
def toy_registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """The registry line ``NAV_COPY,`` in POSITION_STAGES. The accepted run-config sections
    are read from the registry once, when coopproc.run.config is imported, so a stage
    registered later also needs its section there (a registry line in the source does not)."""
    monkeypatch.setitem(POSITION_STAGES, NAV_COPY.name, NAV_COPY)
    monkeypatch.setattr(run_config, "SECTIONS", (*run_config.SECTIONS, NAV_COPY.section))


TOML = '[pipeline]\nranges = []\npositions = ["fusion", "nav_copy"]\n'

#: position_metrics.csv's statistics of the solution itself (the bootstrap bounds
#: ``*_lo``/``*_hi`` are drawn per method, so two identical methods differ in those)
POINT = ["n", "max", "mean", "rmse", "rms_east", "rms_north", "cep50", "cep95"]


@pytest.mark.parametrize("east_m", [0.0, 0.25])
def test_a_toy_family_runs_end_to_end(toy_registered: None, tmp_path: Path, east_m: float) -> None:
    config = tmp_path / "run.toml"
    config.write_text(TOML + f"\n[nav_copy]\neast_m = {east_m}\n")
    out = tmp_path / "out"
    args = ["run", str(SAMPLE), "-o", str(out), "-q", "--no-figures", "--config", str(config)]
    result = CliRunner().invoke(main, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    positions = pd.read_csv(out / "positions.csv")
    assert sorted(positions["method"].unique()) == ["nav", "nav_copy", "observed", "reference"]
    mine = positions[positions["method"] == "nav_copy"].reset_index(drop=True)
    nav = positions[positions["method"] == "nav"].reset_index(drop=True)
    # every nav row once (3 platforms, their range epochs), north and up as they are, east
    # shifted by [nav_copy] east_m: the section reaches the stage
    assert len(mine) == len(nav) == 3528
    for column in ("time", "platform", "north", "up"):
        pd.testing.assert_series_equal(mine[column], nav[column])
    np.testing.assert_allclose(mine["east"] - nav["east"], east_m, atol=1e-9)
    metrics = pd.read_csv(out / "position_metrics.csv").set_index(["method", "platform"])
    copy, own = metrics.loc["nav_copy", POINT], metrics.loc["nav", POINT]
    assert list(copy.index) == ["A", "B", "C"] and list(copy["n"]) == [1131, 1156, 1135]
    if east_m == 0.0:
        pd.testing.assert_frame_equal(copy, own)
    else:
        pd.testing.assert_series_equal(copy["rms_north"], own["rms_north"])
        assert (copy["rms_east"] != own["rms_east"]).all()


def test_config_session_lists_the_toy_family(toy_registered: None, tmp_path: Path) -> None:
    config = tmp_path / "run.toml"
    config.write_text(TOML)
    args = ["config", "--config", str(config), "--session", str(SAMPLE)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    steps = [line for line in result.output.splitlines() if "nav_copy" in line]
    assert any("[needs navigation]" in line for line in steps), result.output
    assert "#   session has: navigation" in result.output
    # its parameters show as their own table, with the help line
    assert "[nav_copy]" in result.output
    assert "shift east of the navigation (m)" in result.output


def test_config_session_marks_what_the_session_lacks(
    toy_registered: None, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """``requires`` is shown against the session; sample_logs has no IMU."""
    needs_imu = dataclasses.replace(NAV_COPY, requires=frozenset({"imu", "navigation"}))
    monkeypatch.setitem(POSITION_STAGES, NAV_COPY.name, needs_imu)
    config = tmp_path / "run.toml"
    config.write_text(TOML)
    args = ["config", "--config", str(config), "--session", str(SAMPLE)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    step = next(line for line in result.output.splitlines() if "nav_copy (observed)" in line)
    assert step.endswith("[needs imu, navigation; MISSING imu]"), step
