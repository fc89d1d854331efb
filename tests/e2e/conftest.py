"""End-to-end fixtures: simulate a session to disk, run the real CLI on it, read back."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main


@dataclass(frozen=True)
class E2ERun:
    """A simulated session, its truth, and the outputs of `coopproc run` on it."""

    session: Path
    out: Path
    truth_events: pd.DataFrame
    ranges: pd.DataFrame
    events: pd.DataFrame
    metrics: pd.DataFrame
    position_metrics: pd.DataFrame
    stderr: str

    def metric(self, pair: str, method: str, column: str) -> float:
        m = self.metrics
        return float(m[(m["pair"] == pair) & (m["method"] == method)][column].iloc[0])

    def position(self, platform: str, method: str, column: str) -> float:
        m = self.position_metrics
        row = m[(m["platform"] == platform) & (m["method"] == method)]
        return float(row[column].iloc[0])


def simulate_and_run(root: Path, scenario: str, seed: int, *extra: str) -> E2ERun:
    """`coopproc simulate` then `coopproc run --no-figures`, both through the CLI."""
    runner = CliRunner()
    session = root / f"{scenario}-{seed}"
    out = root / f"{scenario}-{seed}-out"
    sim = runner.invoke(
        main, ["simulate", str(session), "--scenario", scenario, "--seed", str(seed), *extra]
    )
    assert sim.exit_code == 0, sim.output
    res = runner.invoke(main, ["run", str(session), "-o", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    return E2ERun(
        session=session,
        out=out,
        truth_events=pd.read_csv(session / "truth" / "nlos_events.csv"),
        ranges=pd.read_csv(out / "ranges.csv"),
        events=pd.read_csv(out / "nlos_events.csv"),
        metrics=pd.read_csv(out / "metrics.csv"),
        position_metrics=pd.read_csv(out / "position_metrics.csv"),
        stderr=res.output,
    )


@pytest.fixture(scope="session")
def e2e_runs(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., E2ERun]:
    """Cached simulate+run per (scenario, seed, simulate options) for the whole test
    session (per xdist worker)."""
    cache: dict[tuple[str, int, tuple[str, ...]], E2ERun] = {}
    root = tmp_path_factory.mktemp("e2e")

    def get(scenario: str, seed: int, *extra: str) -> E2ERun:
        key = (scenario, seed, extra)
        if key not in cache:
            where = root / str(len(cache)) if extra else root
            where.mkdir(exist_ok=True)
            cache[key] = simulate_and_run(where, scenario, seed, *extra)
        return cache[key]

    return get
