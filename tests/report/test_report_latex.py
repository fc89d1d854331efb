"""LaTeX tables that fit the page: the layout (always) and, with pdflatex installed, every
table compiled in a one-column and a two-column article with its width measured against
\\linewidth (tests/report/latex_measure.py)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from latex_measure import DOCUMENTS, compile_tables, pdflatex
from report_synth import chain_run, make_run, paper_run

from coopproc.cli import main
from coopproc.report.allan import imu_allan
from coopproc.report.change import Change, change_of
from coopproc.report.evaluation_tables import format_evaluation
from coopproc.report.formats import format_tables
from coopproc.report.latex import COLUMN_PT, SINGLE_PT, SPAN_PT, latex_table, tex_escape
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run
from coopproc.report.stochastic import StochasticReport, uwb_stochastics
from coopproc.report.stochastic_format import format_stochastic
from coopproc.report.tables import POSITION_ALL, build_tables, position_table

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"
#: The documents each layout must fit (names of latex_measure.DOCUMENTS).
FITS = {"single": ("article", "article-2cm"), "double": ("twocolumn", "twocolumn-a4")}


def long_run() -> RunTables:
    """Six position methods, five range methods, long pair / platform / method names."""
    run = chain_run("extra")
    names = {"median": "median_window_25", "lsq": "least_squares_batch"}
    pairs = {"A-B": "rover_alpha-base_bravo", "A-C": "rover_alpha-mast_charlie"}

    def rename(frame: pd.DataFrame, column: str, mapping: dict[str, str]) -> pd.DataFrame:
        out = frame.copy()
        out[column] = out[column].replace(mapping)
        return out

    metrics = rename(rename(run.metrics, "method", names), "pair", pairs)
    extra = metrics[metrics["method"] == "rn"].assign(method="particle_filter_aacopf")
    positions = rename(run.position_metrics, "method", names)
    positions = rename(positions, "platform", {"A": "rover_alpha_long_name"})
    return dataclasses.replace(
        run,
        metrics=pd.concat([metrics, extra], ignore_index=True),
        position_metrics=positions,
    )


def _widths(tex: str) -> list[float]:
    return [float(w) for w in re.findall(r"about (\d+) pt wide", tex)]


def _environments(tex: str) -> list[str]:
    return re.findall(r"\\begin\{(table\*?)\}", tex)


# --- the change rule ------------------------------------------------------------------


def test_change_rule() -> None:
    # magnitudes: relative; signed statistics, dB, % and near-zero references: absolute
    assert change_of(0.05, 0.10, unit="m", decimals=4, signed=False) == Change(-50.0, "%", 1)
    signed = change_of(0.0410, 0.0005, unit="m", decimals=4, signed=True)
    assert signed is not None and signed.text() == "+0.0405 m"  # not "+8100.0%"
    assert change_of(46.36, 41.07, unit="dB", decimals=2, signed=False) == Change(
        pytest.approx(5.29), "dB", 2
    )
    assert change_of(0.5, 0.4, unit="%", decimals=2, signed=False).text() == "+0.10 pp"  # type: ignore[union-attr]
    near = change_of(0.0012, 0.0009, unit="m", decimals=4, signed=False)
    assert near is not None and near.text() == "+0.0003 m"  # |o| < 0.0010 m
    far = change_of(0.0012, 0.0010, unit="m", decimals=4, signed=False)
    assert far is not None and far.text() == "+20.0%"
    assert change_of(1.0, 0.0, unit="", decimals=4, signed=False).text() == "+1.0000"  # type: ignore[union-attr]
    assert change_of(float("nan"), 1.0, unit="m", decimals=4, signed=False) is None
    # a change that rounds to zero carries no sign
    assert Change(-0.0001, "%", 1).text() == "0.0%"


def test_signed_mean_changes_are_absolute_in_every_format() -> None:
    run = paper_run()
    # A-B: observed mean +0.0285 m, RN -0.0255 m: -0.0540 m (not -10.5 % of magnitudes)
    assert "(-0.0540 m)" in format_tables(run, "terminal", metrics=["mean"])
    assert "(-0.0540 m)" in format_tables(run, "md", metrics=["mean"])
    assert "A-B,rn,-0.025500,-0.054000,m," in format_tables(run, "csv", metrics=["mean"])
    assert r"($-$0.0540\,m)" in format_tables(run, "latex", metrics=["mean"])
    # Table 3's mean (of horizontal errors) is a magnitude: relative
    assert "C,di,0.120000,-40.62,%,mean" in format_tables(run, "csv", metrics=["mean"])


def test_no_change_leaves_the_change_out_of_every_format() -> None:
    run = paper_run()
    for fmt in ("terminal", "md", "csv", "latex"):
        text = format_tables(run, fmt, change=False)  # type: ignore[arg-type]
        assert "%)" not in text and "_change" not in text and " m)" not in text, fmt
    assert "-60.6%" in format_tables(run, "terminal")


# --- the LaTeX layout (no pdflatex needed) --------------------------------------------


@pytest.mark.parametrize("run_name", ["paper", "long"])
def test_layout_fits_by_estimate(run_name: str) -> None:
    run = paper_run() if run_name == "paper" else long_run()
    single = format_tables(run, "latex")
    assert r"\resizebox" not in single
    assert single.count(r"% needs \usepackage{booktabs}") == len(_environments(single))
    assert set(_environments(single)) == {"table"}
    assert all(w <= SINGLE_PT for w in _widths(single))
    double = format_tables(run, "latex", latex_width="double")
    for env, width in zip(_environments(double), _widths(double), strict=True):
        assert width <= (COLUMN_PT if env == "table" else SPAN_PT)
    # with the change rows Table 2 is too wide for one column: it spans both
    assert _environments(double)[0] == "table*"
    assert _environments(double)[-1] == "table"  # the NLOS table fits a column


def test_layout_rows() -> None:
    tex = format_tables(paper_run(), "latex", metrics=["max", "mean", "snr_db", "n"])
    table2 = tex.split("% Table 3")[0]
    assert " & Max & Mean & SNR & \\\\" in table2
    assert "Method & (m) & (m) & (dB) & $n$ \\\\" in table2
    assert r"\multicolumn{5}{@{}l}{\textit{Pair A-B}} \\" in table2
    rows = table2.splitlines()
    rn = rows.index(r"RN-Based & 0.3289 & $-$0.0255 & 49.83 & 300 \\")
    assert rows[rn + 1] == (
        r" & {\footnotesize ($-$60.6\,\%)} & {\footnotesize ($-$0.0540\,m)} & "
        r"{\footnotesize (+7.67\,dB)} & \\"
    )
    assert rows[rn - 1].startswith("Observed & ")  # no change row under Observed
    assert r"\textbf{$-$0.0059}" in table2  # best mean: smallest magnitude


def test_a_table_too_wide_for_any_type_is_split() -> None:
    table3 = position_table(paper_run().position_metrics, POSITION_ALL)
    assert len(_environments(latex_table(table3, "double"))) == 1
    # every column three times: wider than both columns even in \footnotesize
    wide = dataclasses.replace(table3, metrics=table3.metrics * 3)
    split = latex_table(wide, "double")
    assert _environments(split) == ["table*"] * len(_widths(split))
    assert len(_widths(split)) >= 2 and all(w <= SPAN_PT for w in _widths(split))
    assert r"\label{tab:table3-2}" in split and "(continued)" in split
    columns = re.findall(r"\\begin\{tabular\}\{@\{\}l(r+)@\{\}\}", split)
    assert sum(len(c) for c in columns) == len(wide.metrics)  # every column once


def test_tex_escape() -> None:
    assert tex_escape(r"a_b & 50% #1 {x} \ ~^") == (
        r"a\_b \& 50\% \#1 \{x\} \textbackslash{} \~{}\^{}"
    )


# --- compiled with pdflatex -----------------------------------------------------------

needs_pdflatex = pytest.mark.skipif(pdflatex() is None, reason="pdflatex is not installed")


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> RunTables:
    if pdflatex() is None:
        pytest.skip("pdflatex is not installed")
    if not SAMPLE.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    out = tmp_path_factory.mktemp("latex") / "run"
    result = CliRunner().invoke(main, ["run", str(SAMPLE), "-o", str(out), "--no-figures", "-q"])
    assert result.exit_code == 0, result.output
    return load_run(out)


def _all_tables(run: RunTables, width: str, evaluation: bool) -> str:
    parts = []
    for change in (True, False):
        kwargs = {"change": change, "latex_width": width}
        parts.append(format_tables(run, "latex", **kwargs))  # type: ignore[arg-type]
        if evaluation:
            parts.append(format_evaluation(run, "latex", align=("none", "se3"), **kwargs))  # type: ignore[arg-type]
    return "\n".join(parts)


def stochastic() -> StochasticReport:
    """The UWB residual table (13 columns) and the gyro / accelerometer Allan tables."""
    rng = np.random.default_rng(3)
    pairs, _ = uwb_stochastics(make_run().ranges)
    t = np.arange(0.0, 120.0, 0.01)
    gyro = rng.normal(0.0, 0.001, (t.size, 3))
    accel = rng.normal(0.0, 0.01, (t.size, 3)) + np.array([0.0, 0.0, 9.80665])
    return StochasticReport(tuple(pairs), (imu_allan("A", "synthetic", t, gyro, accel),))


def test_stochastic_tables_are_split_to_fit() -> None:
    text = format_stochastic(stochastic(), "latex")
    assert len(_environments(text)) >= 4 and all(w <= SINGLE_PT for w in _widths(text))
    assert r"\label{tab:stochastic-2}" in text
    # the pair column starts every part; headers "Mean (m)" as "Mean" over "(m)"
    parts = text.split(r"\begin{tabular}")[1:3]
    assert all("\\toprule\nPair & " in p for p in parts)
    assert "Mean" in parts[0] and " & (m) & " in parts[0]


def _check(tex: str, width: str) -> None:
    count = len(_environments(tex))
    for name in FITS[width]:
        compiled = compile_tables(tex, DOCUMENTS[name])
        assert len(compiled.tables) == count, name
        assert compiled.overfull == [], name
        for table in compiled.tables:
            assert table.width <= table.linewidth, (name, table)
        if width == "double":  # table (one column) or table* (both)
            narrow = [
                t
                for t, env in zip(compiled.tables, _environments(tex), strict=True)
                if env == "table"
            ]
            assert all(t.linewidth < 240 for t in narrow)


@needs_pdflatex
@pytest.mark.parametrize("width", ["single", "double"])
def test_sample_run_tables_compile_and_fit(sample_run: RunTables, width: str) -> None:
    _check(_all_tables(sample_run, width, evaluation=True), width)


@needs_pdflatex
@pytest.mark.parametrize("width", ["single", "double"])
def test_stochastic_tables_compile_and_fit(width: str) -> None:
    _check(format_stochastic(stochastic(), "latex", latex_width=width), width)  # type: ignore[arg-type]


@needs_pdflatex
@pytest.mark.parametrize("width", ["single", "double"])
def test_many_methods_long_names_compile_and_fit(width: str) -> None:
    run = long_run()
    assert len({t.key for t in build_tables(run)}) == 3
    _check(_all_tables(run, width, evaluation=False), width)
