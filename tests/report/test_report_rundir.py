"""Reading an output directory back: round trip, metrics recomputed from ranges.csv, errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from report_synth import make_run

from coopproc.errors import InputError
from coopproc.io.outdir import write_csv
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run


def write_run_dir(run: RunTables, out: Path) -> Path:
    """Write the run's tables the way coopproc run does (coopproc.io.outdir.write_csv)."""
    out.mkdir(parents=True, exist_ok=True)
    for name in (
        "ranges",
        "di",
        "nlos_events",
        "nlos_estimates",
        "positions",
        "metrics",
        "position_metrics",
        "nlos_scores",
        "nlos_event_scores",
    ):
        write_csv(getattr(run, name), out / f"{name}.csv")
    (out / "run.json").write_text(json.dumps(dict(run.info)))
    return out


def test_round_trip(tmp_path: Path) -> None:
    run = make_run()
    loaded = load_run(write_run_dir(run, tmp_path / "out"))
    assert loaded.info == dict(run.info)
    assert loaded.positions["platform"].tolist() == run.positions["platform"].tolist()
    np.testing.assert_allclose(loaded.ranges["observed"], run.ranges["observed"], atol=1e-6)
    assert loaded.nlos_scores is not None and run.nlos_scores is not None
    assert len(loaded.nlos_scores) == len(run.nlos_scores)


def test_metrics_csv_equals_recomputation_from_ranges_csv(tmp_path: Path) -> None:
    loaded = load_run(write_run_dir(make_run(), tmp_path / "out"))
    again = distance_metrics(loaded.ranges)
    pd.testing.assert_frame_equal(
        again[["pair", "method", "n"]], loaded.metrics[["pair", "method", "n"]]
    )
    for col in ("max", "mean", "rmse", "snr_db", "smoothness"):
        # CSV values carry 6 decimals; a recomputation from the rounded ranges agrees to that
        np.testing.assert_allclose(again[col], loaded.metrics[col], rtol=1e-5, atol=2e-6)
    pos_again = position_metrics(loaded.positions)
    np.testing.assert_allclose(pos_again["rmse"], loaded.position_metrics["rmse"], atol=2e-6)


def test_optional_tables_may_be_missing(tmp_path: Path) -> None:
    out = write_run_dir(make_run(), tmp_path / "out")
    for name in ("nlos_estimates", "nlos_scores", "nlos_event_scores"):
        (out / f"{name}.csv").unlink()
    run = load_run(out)
    assert run.nlos_scores is None and len(run.nlos_estimates) == 0


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda out: (out / "metrics.csv").unlink(), r"metrics.csv: missing; is this an output"),
        (lambda out: (out / "run.json").write_text("{"), r"run.json: not valid JSON"),
        (
            lambda out: (out / "positions.csv").write_text("time,platform\n1,A\n"),
            r"positions.csv:1: missing columns \['method', 'east'",
        ),
        (
            lambda out: (out / "metrics.csv").write_text(
                "pair,method,max,mean,rmse,snr_db,smoothness,n\nA-B,di,0.1,x,0.1,40,1,3\n"
            ),
            r"metrics.csv:2: column 'mean': expected a number, found 'x'",
        ),
    ],
)
def test_clear_errors(tmp_path: Path, damage, message: str) -> None:  # type: ignore[no-untyped-def]
    out = write_run_dir(make_run(), tmp_path / "out")
    damage(out)
    with pytest.raises(InputError, match=message):
        load_run(out)


def test_not_a_directory(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not an output directory"):
        load_run(tmp_path / "nothing")
