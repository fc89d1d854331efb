"""`coopproc run --format parquet` ([run] format): the per-epoch tables as Parquet, read
back by report, export and batch as the CSV ones."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner, Result

from coopproc.cli import main
from coopproc.report.rundir import PARQUET_TABLES, load_run

pytest.importorskip("pyarrow")

SUMMARIES = (
    "nlos_events.csv",
    "metrics.csv",
    "position_metrics.csv",
    "nlos_scores.csv",
    "nlos_event_scores.csv",
    "evaluation.csv",
    "rpe.csv",
)


def _cli(*args: str | Path) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """A simulated session, its run as CSV and its run with --format parquet."""
    base = tmp_path_factory.mktemp("parquet")
    session = base / "session"
    res = _cli("simulate", session, "--scenario", "paper-table1", "--seed", "7", "--duration", "60")
    assert res.exit_code == 0, res.output
    res = _cli("run", session, "-o", base / "csv", "--no-figures", "-q")
    assert res.exit_code == 0, res.output
    res = _cli("run", session, "-o", base / "parquet", "--no-figures", "--format", "parquet")
    assert res.exit_code == 0, res.output
    assert "(10 CSV, 4 Parquet)" in res.output  # range_weights.csv, comparisons.csv stay CSV
    return session, base / "csv", base / "parquet"


def test_per_epoch_tables_are_parquet_with_the_numbers_of_the_csv(
    runs: tuple[Path, Path, Path],
) -> None:
    _, csv_run, pq_run = runs
    for name in PARQUET_TABLES:
        stem = name.removesuffix(".csv")
        assert not (pq_run / name).exists()
        from_csv = pd.read_csv(csv_run / name, dtype={"pair": str, "platform": str, "method": str})
        from_parquet = pd.read_parquet(pq_run / f"{stem}.parquet")
        assert len(from_parquet) == len(from_csv) > 0 or stem == "nlos_estimates"
        # the floats are those the CSV text holds (rounded to its 6 decimals)
        pd.testing.assert_frame_equal(
            from_parquet, from_csv, check_dtype=False, check_exact=False, atol=1e-9, rtol=0
        )
    positions = pd.read_parquet(pq_run / "positions.parquet")
    east = positions["east"].dropna().to_numpy()
    assert np.array_equal(np.round(east, 6), east)  # written at the CSV precision
    for name in SUMMARIES:  # the summary tables stay CSV, byte for byte
        assert (pq_run / name).read_bytes() == (csv_run / name).read_bytes()


def test_run_json_records_the_format(runs: tuple[Path, Path, Path]) -> None:
    _, csv_run, pq_run = runs
    assert json.loads((pq_run / "run.json").read_text())["config"]["run"]["format"] == "parquet"
    assert json.loads((csv_run / "run.json").read_text())["config"]["run"]["format"] == "csv"


@pytest.mark.parametrize(
    "args",
    [
        ["--table"],
        ["--format", "csv"],
        ["--evaluate", "--align", "none,se3"],
        ["--metrics", "max,rmse", "--pairs", "A-B"],
    ],
)
def test_report_shows_the_same_numbers(runs: tuple[Path, Path, Path], args: list[str]) -> None:
    _, csv_run, pq_run = runs
    from_csv = _cli("report", csv_run, *args)
    from_parquet = _cli("report", pq_run, *args)
    assert from_csv.exit_code == from_parquet.exit_code == 0, from_parquet.output
    assert from_parquet.output == from_csv.output
    assert any(ch.isdigit() for ch in from_csv.output)


def test_load_run_reads_either_form(runs: tuple[Path, Path, Path]) -> None:
    _, csv_run, pq_run = runs
    a, b = load_run(csv_run), load_run(pq_run)
    for attr in ("ranges", "di", "nlos_estimates", "positions", "metrics"):
        pd.testing.assert_frame_equal(
            getattr(b, attr), getattr(a, attr), check_dtype=False, atol=1e-9, rtol=0
        )


def test_export_reads_a_parquet_run(runs: tuple[Path, Path, Path], tmp_path: Path) -> None:
    _, csv_run, pq_run = runs
    assert _cli("export", csv_run, "--format", "tum", "-o", tmp_path / "a").exit_code == 0
    assert _cli("export", pq_run, "--format", "tum", "-o", tmp_path / "b").exit_code == 0
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files and files == sorted(p.name for p in (tmp_path / "b").iterdir())
    for name in files:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.slow
def test_config_key_gives_the_same_bytes_again(
    runs: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    session, _, pq_run = runs
    config = tmp_path / "run.toml"
    config.write_text('[run]\nformat = "parquet"\n')
    res = _cli("run", session, "-o", tmp_path / "again", "-c", config, "--no-figures", "-q")
    assert res.exit_code == 0, res.output
    for name in PARQUET_TABLES:
        stem = name.removesuffix(".csv")
        again = (tmp_path / "again" / f"{stem}.parquet").read_bytes()
        assert again == (pq_run / f"{stem}.parquet").read_bytes()
    # --format on the command line wins over the config
    res = _cli("run", session, "-o", tmp_path / "c", "-c", config, "--format", "csv", "-q")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "c" / "positions.csv").is_file()
    assert not (tmp_path / "c" / "positions.parquet").exists()


def test_bad_format_in_the_config_is_one_line(
    tmp_path: Path, runs: tuple[Path, Path, Path]
) -> None:
    config = tmp_path / "run.toml"
    config.write_text('[run]\nformat = "feather"\n')
    res = _cli("run", runs[0], "-o", tmp_path / "x", "-c", config)
    assert res.exit_code == 1
    assert res.output.count("\n") == 1 and "format" in res.output and "parquet" in res.output


def test_without_pyarrow_parquet_is_a_one_line_error(
    runs: tuple[Path, Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    session, _, pq_run = runs
    for module in ("pyarrow", "pyarrow.parquet"):
        monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    out = tmp_path / "out"
    res = _cli("run", session, "-o", out, "--format", "parquet")
    assert res.exit_code == 1
    assert res.stderr == (
        "error: Parquet output needs pyarrow, which is not installed: "
        'pip install "coopproc[parquet]"\n'
    )
    assert not out.exists()
    res = _cli("report", pq_run, "--table")
    assert res.exit_code == 1
    assert res.stderr.count("\n") == 1 and 'pip install "coopproc[parquet]"' in res.stderr


@pytest.mark.slow  # three batches of runs
def test_batch_pools_and_resumes_parquet_runs(
    runs: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    session, csv_run, _ = runs
    config = tmp_path / "run.toml"
    config.write_text('[run]\nformat = "parquet"\n')
    root = tmp_path / "root"
    args = [session, "-o", root, "-c", config, "--threads", "-j", "1", "--no-figures"]
    res = _cli("batch", *args)
    assert res.exit_code == 0, res.output
    assert (root / "session" / "positions.parquet").is_file()
    pooled = pd.read_csv(root / "pooled_position_metrics.csv")
    assert len(pooled) > 0
    # the same pooled numbers as a batch of CSV runs
    csv_root = tmp_path / "csv_root"
    res = _cli("batch", session, "-o", csv_root, "--threads", "-j", "1", "--no-figures")
    assert res.exit_code == 0, res.output
    pooled_csv = (csv_root / "pooled_position_metrics.csv").read_bytes()
    assert (root / "pooled_position_metrics.csv").read_bytes() == pooled_csv
    # a complete parquet run is current: --resume keeps it
    res = _cli("batch", *args, "--resume")
    assert res.exit_code == 0, res.output
    assert "1 skipped (complete and current)" in res.output
    assert csv_run.is_dir()


def test_row_groups_and_categorical_text_read_back_as_one_table(tmp_path: Path) -> None:
    from coopproc.io.parquet import write_parquet

    frame = pd.DataFrame(
        {
            "time": np.arange(7) + 0.12345678,
            "platform": pd.Categorical.from_codes([0, 0, 1, 1, 1, 2, 2], ["A", "B", "C"]),
            "east": np.linspace(-1.0, 1.0, 7) / 3,
        }
    )
    whole = pd.read_parquet(write_parquet(frame, tmp_path / "whole.parquet"))
    path = write_parquet(frame, tmp_path / "groups.parquet", row_group_rows=3)
    import pyarrow.parquet as pq

    assert pq.ParquetFile(path).num_row_groups == 3
    groups = pd.read_parquet(path)
    pd.testing.assert_frame_equal(groups, whole)
    assert groups["platform"].tolist() == ["A", "A", "B", "B", "B", "C", "C"]
    assert not isinstance(groups["platform"].dtype, pd.CategoricalDtype)  # text, as the CSV
    assert groups["time"].tolist() == [float(f"{t:.6f}") for t in frame["time"]]
