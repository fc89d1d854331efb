"""Partial chains and the worked example of docs/extending.md, end to end through the CLI
on the shipped sample session: what each writes, and that the steps they share with the
default chain give the same numbers."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"


def _run(out: Path, toml: str | None, *extra: str) -> Path:
    args = ["run", str(SAMPLE), "-o", str(out), "-q", *extra]
    if toml is not None:
        config = out.parent / f"{out.name}.toml"
        config.write_text(toml)
        args += ["--config", str(config)]
    result = CliRunner().invoke(main, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return out


def _csv(out: Path, name: str) -> pd.DataFrame:
    return pd.read_csv(out / name, keep_default_na=True)


@pytest.fixture(scope="module")
def default_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _run(tmp_path_factory.mktemp("chain") / "default", None, "--no-figures")


def test_fusion_only(default_run: Path, tmp_path: Path) -> None:
    out = _run(tmp_path / "fusion", "[pipeline]\nranges = []\n", "--no-figures")
    ranges = _csv(out, "ranges.csv")
    assert list(ranges.columns) == [
        "time", "pair", "observed", "reference", "nlos_flag", "nlos_estimate", "outlier"
    ]  # fmt: skip
    assert (ranges["nlos_flag"] == 0).all() and (ranges["nlos_estimate"] == 0).all()
    assert (ranges["outlier"] == 0).all()
    assert _csv(out, "nlos_events.csv").empty and _csv(out, "di.csv").empty
    positions = _csv(out, "positions.csv")
    assert sorted(positions["method"].unique()) == ["nav", "observed", "reference"]
    # the observed fusion is the default chain's first step: the same positions
    default = _csv(default_run, "positions.csv")
    mine = positions[positions["method"] == "observed"].reset_index(drop=True)
    theirs = default[default["method"] == "observed"].reset_index(drop=True)
    pd.testing.assert_frame_equal(mine, theirs)
    assert sorted(_csv(out, "metrics.csv")["method"].unique()) == ["observed"]
    info = json.loads((out / "run.json").read_text())
    assert info["methods"] == {
        "ranges": ["observed"],
        "positions": ["observed"],
        "nlos": [],
        "primary": [],
    }
    assert [s["step"] for s in info["pipeline"]] == ["fusion (observed)"]
    assert info["config"]["pipeline"] == {
        "ranges": [],
        "positions": ["fusion"],
        "observed_only": [],
        "anchor_methods": True,
    }


def test_di_without_rn(default_run: Path, tmp_path: Path) -> None:
    out = _run(tmp_path / "di", '[pipeline]\nranges = ["di"]\n', "--no-figures")
    ranges = _csv(out, "ranges.csv")
    assert list(ranges.columns) == [
        "time", "pair", "observed", "di", "reference", "nlos_flag", "nlos_estimate", "outlier"
    ]  # fmt: skip
    default = _csv(default_run, "ranges.csv")
    # DI-Based does not depend on RN-Based: the same distances, flags and events
    pd.testing.assert_frame_equal(ranges, default.drop(columns="rn"))
    events = _csv(out, "nlos_events.csv")
    assert set(events["method"]) == {"di"}
    default_events = _csv(default_run, "nlos_events.csv")
    pd.testing.assert_frame_equal(
        events, default_events[default_events["method"] == "di"].reset_index(drop=True)
    )
    positions = _csv(out, "positions.csv")
    assert sorted(positions["method"].unique()) == ["di", "nav", "observed", "reference"]
    pm = _csv(out, "position_metrics.csv")
    default_pm = _csv(default_run, "position_metrics.csv")
    pd.testing.assert_frame_equal(
        pm, default_pm[default_pm["method"] != "rn"].reset_index(drop=True)
    )
    info = json.loads((out / "run.json").read_text())
    assert [s["step"] for s in info["pipeline"]] == [
        "fusion (observed)",
        "ranging (di)",
        "fusion (di)",
    ]
    assert info["method_labels"] == {"di": "DI-Based"}  # the registry's, for the report


@pytest.mark.slow  # a run with every figure (docs/extending.md's worked example)
def test_median_worked_example(default_run: Path, tmp_path: Path) -> None:
    """docs/extending.md: the median processor added to the default chain."""
    toml = '[pipeline]\nranges = ["rn", "di", "median"]\n\n[median]\nwindow = 7\n'
    out = _run(tmp_path / "median", toml)
    ranges = _csv(out, "ranges.csv")
    assert list(ranges.columns[:6]) == ["time", "pair", "observed", "rn", "di", "median"]
    # the column is each pair's centred running median of 7 observed ranges
    for _, group in ranges.groupby("pair"):
        obs = group["observed"].to_numpy()
        expected = [np.median(obs[max(i - 3, 0) : i + 4]) for i in range(obs.shape[0])]
        np.testing.assert_allclose(group["median"].to_numpy(), expected, atol=1e-6)
    # the default chain's columns are untouched
    default = _csv(default_run, "ranges.csv")
    pd.testing.assert_frame_equal(ranges.drop(columns="median"), default)
    metrics = _csv(out, "metrics.csv").set_index(["pair", "method"])
    # a median halves white noise on the line-of-sight pair, and keeps NLOS biases
    assert metrics.loc[("A-C", "median"), "rmse"] < 0.7 * metrics.loc[("A-C", "observed"), "rmse"]
    assert metrics.loc[("A-B", "median"), "rmse"] > 3 * metrics.loc[("A-B", "di"), "rmse"]
    positions = _csv(out, "positions.csv")
    assert "median" in set(positions["method"])
    assert "median" in set(_csv(out, "position_metrics.csv")["method"])
    info = json.loads((out / "run.json").read_text())
    assert info["methods"]["ranges"] == ["observed", "rn", "di", "median"]
    assert info["config"]["median"] == {"window": 7}
    assert "median (median)" in [s["step"] for s in info["pipeline"]]
    assert (out / "report.html").read_text().count("median") > 3
    table = CliRunner().invoke(main, ["report", str(out), "--table"])
    assert table.exit_code == 0 and "median" in table.output


def test_lsq_needs_anchors(tmp_path: Path) -> None:
    config = tmp_path / "lsq.toml"
    config.write_text('[pipeline]\npositions = ["fusion", "lsq"]\n')
    result = CliRunner().invoke(
        main, ["run", str(SAMPLE), "-o", str(tmp_path / "out"), "--config", str(config)]
    )
    assert result.exit_code == 1
    assert "error: lsq: the session has no anchors" in result.output
    assert not (tmp_path / "out").exists()
