"""Figures: valid image files of the expected size, and the plotted data equal the CSV data."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from report_synth import make_run
from test_report_rundir import write_run_dir

from coopproc.errors import ConfigError
from coopproc.report.figures import FIGURE_NAMES, make_figures, write_figures
from coopproc.report.plots import plot_distance_errors
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run
from coopproc.report.style import COLUMN_WIDTH_IN, PANEL_HEIGHT_IN


@pytest.fixture(scope="module")
def loaded(tmp_path_factory: pytest.TempPathFactory) -> RunTables:
    return load_run(write_run_dir(make_run(), tmp_path_factory.mktemp("run") / "out"))


@pytest.fixture(scope="module")
def figures(loaded: RunTables) -> dict[str, Figure]:
    return make_figures(loaded)


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def line(ax: Axes, gid: str) -> tuple[np.ndarray, np.ndarray]:
    found = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    assert len(found) == 1, gid
    return np.asarray(found[0].get_xdata(), float), np.asarray(found[0].get_ydata(), float)


@pytest.mark.slow
def test_files_are_pngs_of_the_expected_size(loaded: RunTables, tmp_path: Path) -> None:
    paths = write_figures(loaded, tmp_path / "figures", dpi=100)
    assert [p.stem for p in paths] == list(FIGURE_NAMES)
    # three pairs stacked, one journal column wide
    assert png_size(tmp_path / "figures" / "distance_errors.png") == (
        round(COLUMN_WIDTH_IN * 100),
        round((0.55 + 3 * PANEL_HEIGHT_IN) * 100),
    )
    assert png_size(tmp_path / "figures" / "position_errors.png") == (
        round(COLUMN_WIDTH_IN * 100),
        round((0.55 + 2 * PANEL_HEIGHT_IN) * 100),
    )
    for path in paths:
        width, height = png_size(path)
        assert 300 <= width <= 800 and 200 <= height <= 800


@pytest.mark.slow
def test_pdf_svg_and_bad_format(loaded: RunTables, tmp_path: Path) -> None:
    paths = write_figures(loaded, tmp_path, formats=("pdf", "svg"), dpi=50)
    pdfs = [p for p in paths if p.suffix == ".pdf"]
    assert len(pdfs) == len(FIGURE_NAMES) and pdfs[0].read_bytes().startswith(b"%PDF")
    assert b"<svg" in next(p for p in paths if p.suffix == ".svg").read_bytes()[:2000]
    with pytest.raises(ConfigError, match="unknown figure format 'jpg'"):
        write_figures(loaded, tmp_path, formats=("jpg",))


@pytest.mark.slow
def test_same_run_gives_same_png_bytes(loaded: RunTables, tmp_path: Path) -> None:
    a = write_figures(loaded, tmp_path / "a", dpi=40)
    b = write_figures(loaded, tmp_path / "b", dpi=40)
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]


def test_distance_errors_plot_the_csv(loaded: RunTables, figures: dict[str, Figure]) -> None:
    axes = figures["distance_errors"].axes
    assert [ax.get_title(loc="left") for ax in axes] == ["(a) A-B", "(b) A-C", "(c) B-C"]
    t0 = loaded.time_origin_s
    ab = loaded.ranges[loaded.ranges["pair"] == "A-B"]
    for method in ("observed", "rn", "di"):
        x, y = line(axes[0], method)
        np.testing.assert_allclose(x + t0, ab["time"])
        np.testing.assert_allclose(y, ab[method] - ab["reference"], atol=1e-12)
    spans = [p for p in axes[0].patches if p.get_gid() == "nlos_span"]
    event = loaded.nlos_events.query("pair == 'A-B' and method == 'di'").iloc[0]
    assert len(spans) == 1
    span = spans[0]
    x0 = span.get_x()  # type: ignore[attr-defined]
    x1 = x0 + span.get_width()  # type: ignore[attr-defined]
    assert (x0 + t0, x1 + t0) == pytest.approx((event["start"], event["end"]))
    assert axes[0].get_ylabel() == "Distance error (m)"
    assert axes[-1].get_xlabel() == "Time since t0 = 1000.0 (s)"
    assert figures["distance_errors"].legends  # one shared legend


def test_di_position_convergence_and_trajectory_plot_the_csv(
    loaded: RunTables, figures: dict[str, Figure]
) -> None:
    t0 = loaded.time_origin_s
    di = loaded.di[(loaded.di["pair"] == "B-C") & loaded.di["di_reference"].notna()]
    x, y = line(figures["di_errors"].axes[2], "di_smoothed")
    np.testing.assert_allclose(x + t0, di["time"])
    np.testing.assert_allclose(y, di["di_smoothed"] - di["di_reference"], atol=1e-12)

    pos = loaded.positions.query("platform == 'C' and method == 'rn'")
    x, y = line(figures["position_errors"].axes[1], "rn")
    np.testing.assert_allclose(x + t0, pos["time"])
    np.testing.assert_allclose(y, pos["error_h"])

    conv = figures["nlos_convergence"].axes
    assert len(conv) == 2  # one panel per DI event (A-B, B-C); RN joins by time overlap
    est = loaded.nlos_estimates.query("pair == 'A-B' and method == 'rn'")
    x, y = line(conv[0], "rn")
    np.testing.assert_allclose(x, est["step"])
    np.testing.assert_allclose(y, est["estimate"])
    _, bias = line(conv[0], "reference_bias")
    assert loaded.nlos_event_scores is not None
    expected = loaded.nlos_event_scores.query("pair == 'A-B' and method == 'di'")
    assert bias[0] == pytest.approx(expected["reference_bias"].iloc[0], abs=1e-6)

    traj = figures["trajectories"].axes[0]
    ref = loaded.positions.query("platform == 'A' and method == 'reference'")
    x, y = line(traj, "reference")
    np.testing.assert_allclose(x, ref["east"])
    np.testing.assert_allclose(y, ref["north"])


def test_axes_function_draws_on_given_axes() -> None:
    fig = Figure()
    ax = fig.add_subplot()
    rows = pd.DataFrame(
        {"time": [3.0, 1.0, 2.0], "observed": [5.0, 4.0, np.nan], "reference": [4.5, 4.0, 4.2]}
    )
    assert plot_distance_errors(ax, rows, methods=("observed",), time_origin_s=1.0) is ax
    x, y = line(ax, "observed")
    np.testing.assert_allclose(x, [0.0, 2.0])
    np.testing.assert_allclose(y, [0.0, 0.5])


def test_figures_without_data_are_skipped(loaded: RunTables) -> None:
    bare = RunTables(
        ranges=loaded.ranges.assign(reference=np.nan),
        di=loaded.di.assign(di_reference=np.nan),
        nlos_events=loaded.nlos_events,
        nlos_estimates=loaded.nlos_estimates.iloc[0:0],
        positions=loaded.positions.assign(error_h=np.nan),
        metrics=loaded.metrics,
        position_metrics=loaded.position_metrics,
    )
    assert list(make_figures(bare)) == ["trajectories"]
