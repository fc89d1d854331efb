"""report.html holds every table and figure; the `coopproc report` command."""

from __future__ import annotations

import base64
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from report_synth import make_run
from test_report_rundir import write_run_dir

from coopproc.cli import main
from coopproc.report.figures import FIGURE_NAMES, write_figures
from coopproc.report.formats import format_tables
from coopproc.report.html import write_html
from coopproc.report.rundir import load_run


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_run_dir(make_run(), tmp_path_factory.mktemp("html") / "out")


def test_html_has_every_table_and_figure(out_dir: Path) -> None:
    run = load_run(out_dir)
    figs = write_figures(run, out_dir / "figures", dpi=40)
    page = write_html(out_dir, run).read_text()
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    for caption in (
        "Table 2. Distance errors per pair and method",
        "Table 3. Horizontal position errors per platform and method",
        "NLOS detection against the reference",
        "NLOS events against the reference",
        "Inputs",
    ):
        assert f"<caption>{caption}</caption>" in page
    for column in ("RMS E (m)", "CEP95 (m)", "SNR (dB)", "F1"):
        assert f"<th>{column}</th>" in page
    images = dict(re.findall(r'<img alt="(\w+)" src="data:image/png;base64,([^"]+)"', page))
    assert list(images) == list(FIGURE_NAMES)
    for path in figs:  # the embedded bytes are the files' bytes
        assert base64.b64decode(images[path.stem]) == path.read_bytes()
    assert 'src="http' not in page and "<link" not in page  # self-contained
    assert "synthetic" in page and "ab" * 32 in page  # run facts


def test_html_renders_figures_when_none_on_disk(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    page = write_html(out, load_run(out)).read_text()
    assert page.count("data:image/png;base64,") == len(FIGURE_NAMES)


def test_cli_table_default_equals_library(out_dir: Path) -> None:
    result = CliRunner().invoke(main, ["report", str(out_dir)])
    assert result.exit_code == 0, result.output
    assert result.output == format_tables(load_run(out_dir), "terminal")


def test_cli_formats_filters_and_output_file(out_dir: Path, tmp_path: Path) -> None:
    target = tmp_path / "t.tex"
    args = ["report", str(out_dir), "--format", "latex", "-o", str(target)]
    result = CliRunner().invoke(main, [*args, "--metrics", "max,rmse", "--pairs", "A-B"])
    assert result.exit_code == 0, result.output
    assert result.output == f"wrote {target}\n"
    tex = target.read_text()
    assert r"\toprule" in tex and " & Max & RMSE \\" in tex and "B-C" not in tex
    assert "Method & (m) & (m) \\" in tex and r"\begin{table}" in tex
    # --latex-width double, --no-change: one column of a two-column page, no change rows
    narrow = ["--metrics", "max,rmse", "--pairs", "A-B", "--latex-width", "double"]
    CliRunner().invoke(main, [*args, *narrow, "--no-change"])
    tex = target.read_text()
    table2 = tex.split("% Table 3")[0]
    assert r"\begin{table}" in table2 and "one column of a two-column" in table2
    assert r"\%" not in table2.split(r"\begin{tabular}")[1]


def test_cli_errors_are_one_line(out_dir: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["report", str(out_dir), "--metrics", "rmes"])
    assert result.exit_code == 1
    assert result.output == (
        "error: unknown metric 'rmes'; did you mean 'rmse'? (known: max, mean, rmse, snr_db, "
        "smoothness, n, rms_east, rms_north, cep50, cep95, rms_up, max_east, max_north, max_up, "
        "rms_vel_east, rms_vel_north, rms_vel_up, rms_roll, rms_pitch, rms_yaw, precision, "
        "recall, f1, events, estimate_mae, down_weighted, rejected, tp, fp, fn)\n"
    )
    missing = CliRunner().invoke(main, ["report", str(tmp_path)])
    assert missing.exit_code == 1
    assert missing.output == (
        f"error: {tmp_path / 'ranges.csv'}: missing; is this an output directory of coopproc run?\n"
    )


@pytest.mark.slow  # every figure drawn as PNG and SVG
def test_cli_plots_and_html(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    result = CliRunner().invoke(main, ["report", str(out), "--svg", "--dpi", "50", "--html"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[-1] == f"wrote {out / 'report.html'}"
    assert {Path(x.removeprefix("wrote ")).name for x in lines[:-1]} == {
        f"{n}.{ext}" for n in FIGURE_NAMES for ext in ("png", "svg")
    }
    assert "Table 2" not in result.output  # no table unless asked


def test_cli_help() -> None:
    result = CliRunner().invoke(main, ["report", "--help"])
    assert result.exit_code == 0 and "--format" in result.output and "--plots" in result.output
