"""Trajectory panels (start / end / anchors / zoomed inset), the journal style presets,
panel labels past (z) and --pairs / --platforms in every figure kind."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from PIL import Image
from report_synth import make_run
from test_report_rundir import write_run_dir

from coopproc.cli import main
from coopproc.cli.options import STYLE_CHOICES
from coopproc.report.figures import make_figures
from coopproc.report.pages import FigureOptions
from coopproc.report.panels import Panels, grid_layout
from coopproc.report.run_tables import RunTables
from coopproc.report.style import STYLE_NAMES, STYLES, figure_style
from coopproc.report.trajectory_plots import plot_trajectory, run_anchors

ANCHORS = {"U1": [-5.0, 2.0, 0.0], "U2": [30.0, -4.0, 0.0]}


@pytest.fixture(scope="module")
def run() -> RunTables:
    base = make_run(n=80)
    info = dict(base.info)
    info["session"] = {**info["session"], "anchors": ANCHORS}
    return dataclasses.replace(base, info=info)


def legend_labels(fig: Figure) -> list[str]:
    return [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def by_gid(ax: Axes, gid: str) -> list[object]:
    return [line for line in ax.lines if line.get_gid() == gid]


def _track(method: str, offset_m: float, n: int = 400) -> pd.DataFrame:
    """A 150 m straight-and-turn track; the method ``offset_m`` north of the reference."""
    t = np.arange(n, dtype=float)
    east = np.where(t < 300, 0.5 * t, 150.0)
    north = np.where(t < 300, 0.0, 0.5 * (t - 300)) + offset_m
    return pd.DataFrame(
        {
            "time": t,
            "platform": "A",
            "method": method,
            "east": east,
            "north": north,
            "up": 0.0,
            "error_h": np.nan if method == "reference" else abs(offset_m),
        }
    )


def test_start_end_and_anchors_are_in_the_legend(run: RunTables) -> None:
    fig = make_figures(run)["trajectories"]
    labels = legend_labels(fig)
    assert {"Start", "End", "Anchor", "Reference"} <= set(labels)
    ax = fig.axes[0]
    ref = run.positions.query("platform == 'A' and method == 'reference'").sort_values("time")
    (start,) = by_gid(ax, "start")
    (end,) = by_gid(ax, "end")
    assert start.get_label() == "Start" and end.get_label() == "End"  # type: ignore[attr-defined]
    assert start.get_xydata().tolist() == [[ref["east"].iloc[0], ref["north"].iloc[0]]]  # type: ignore[attr-defined]
    assert end.get_xydata().tolist() == [[ref["east"].iloc[-1], ref["north"].iloc[-1]]]  # type: ignore[attr-defined]
    (anchors,) = by_gid(ax, "anchors")
    assert anchors.get_marker() == "^" and anchors.get_linestyle() == "None"  # type: ignore[attr-defined]
    assert anchors.get_xydata().tolist() == [[-5.0, 2.0], [30.0, -4.0]]  # type: ignore[attr-defined]
    assert [t.get_text() for t in ax.texts] == ["U1", "U2"]
    # the error-coloured track marks them too
    track = make_figures(run)["error_track"]
    assert {"Start", "End", "Anchor"} <= set(legend_labels(track))


def test_no_anchor_marker_without_anchors() -> None:
    run = make_run(n=80)
    assert run_anchors(run) == {}
    fig = make_figures(run)["trajectories"]
    assert not by_gid(fig.axes[0], "anchors")
    assert "Anchor" not in legend_labels(fig)


def test_zoomed_inset_where_the_methods_overlap() -> None:
    rows = pd.concat([_track("reference", 0.0), _track("observed", 0.06), _track("di", 0.02)])
    fig = Figure()
    ax = fig.add_subplot()
    plot_trajectory(ax, rows, methods=("reference", "observed", "di"))
    (inset,) = [a for a in ax.child_axes if a.get_gid() == "zoom"]
    lo, hi = inset.get_xlim()
    assert 0.06 < hi - lo < 1.0  # centimetres apart: a window of decimetres, not 150 m
    drawn = {line.get_gid() for line in inset.lines}
    assert drawn == {"reference", "observed", "di"}
    # apart by metres on the same track: no inset needed
    rows = pd.concat([_track("reference", 0.0), _track("observed", 8.0)])
    fig = Figure()
    ax = fig.add_subplot()
    plot_trajectory(ax, rows, methods=("reference", "observed"))
    assert not ax.child_axes


def test_trajectory_breaks_at_gaps() -> None:
    rows = _track("reference", 0.0)
    rows = rows[(rows["time"] < 100) | (rows["time"] > 160)]  # 60 s without data
    fig = Figure()
    ax = fig.add_subplot()
    plot_trajectory(ax, rows, methods=("reference",), zoom=False)
    (line,) = by_gid(ax, "reference")
    x = line.get_xdata()  # type: ignore[attr-defined]
    assert np.isnan(x).sum() == 1  # no chord from 50 m to 80 m east


@pytest.mark.parametrize(
    ("name", "width_in", "tick_pt"),
    [("single-column", 3.5, 8.0), ("double-column", 7.16, 8.0), ("default", None, 7.0)],
)
def test_style_presets_set_width_and_fonts(
    run: RunTables, name: str, width_in: float | None, tick_pt: float
) -> None:
    figs = make_figures(run, FigureOptions(style=STYLES[name]))
    assert set(figs) >= {"distance_errors", "trajectories", "error_track", "error_cdf"}
    for stem, fig in figs.items():
        if width_in is not None:
            assert fig.get_figwidth() == pytest.approx(width_in), stem
        ax = fig.axes[0]
        tick = ax.yaxis.get_major_ticks()[0].label1
        assert tick.get_fontsize() == pytest.approx(tick_pt), stem
        assert ax.title.get_fontsize() == pytest.approx(STYLES[name].text_pt), stem
    if name == "default":  # unchanged: stacks one column, 3 panels a row at 7 in
        assert figs["distance_errors"].get_figwidth() == pytest.approx(3.5)
        assert figs["trajectories"].get_figwidth() == pytest.approx(7.0)
    if name == "single-column":  # at most 2 panels a row
        cols = {round(a.get_position().x0, 2) for a in figs["trajectories"].axes}
        assert len(cols) <= 2


def test_style_names_agree_and_unknown_fails() -> None:
    assert STYLE_CHOICES == STYLE_NAMES
    with pytest.raises(Exception, match="unknown figure style 'ieee'"):
        figure_style("ieee")


def test_panel_labels_continue_past_z_on_a_page() -> None:
    keys = [f"k{i}" for i in range(30)]
    panels = Panels(keys, keys, grid_layout(1.0), lambda ax, i: None)
    fig = panels.page(range(30))
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert titles[25:28] == ["(z) k25", "(aa) k26", "(ab) k27"]
    assert titles[-1] == "(ad) k29"


def _panels(path: Path) -> list[str]:
    with Image.open(path) as image:
        return str(image.info["Panels"]).split("; ")


@pytest.mark.slow  # every figure drawn through the CLI
def test_cli_pairs_and_style_reach_every_figure(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    args = ["report", str(out), "--plots", "--pairs", "B-C", "--style", "single-column"]
    result = CliRunner().invoke(main, [*args, "--dpi", "50"])
    assert result.exit_code == 0, result.output
    figures = sorted((out / "figures").glob("*.png"))
    names = {p.stem for p in figures}
    assert {"distance_errors", "di_errors", "nlos_convergence", "trajectories"} <= names
    for path in figures:
        keys = _panels(path)
        if path.stem in ("distance_errors", "di_errors"):
            assert keys == ["B-C"], path.stem
        elif path.stem == "nlos_convergence":
            assert keys and all(k.startswith("B-C") for k in keys), keys
        else:  # per platform: only the chosen pair's platforms (A is left out)
            assert keys and set(keys) <= {"B", "C"}, (path.stem, keys)
        with Image.open(path) as image:
            assert image.width == round(3.5 * 50), path.stem


def test_locate_trajectory_marks_auxiliaries_start_and_end() -> None:
    from types import SimpleNamespace

    from coopproc.report.locate_figures import plot_locate_trajectories

    t = np.arange(50, dtype=float)
    ref = np.column_stack([t, 0.5 * t])
    aux = np.column_stack([10 - t, t])[:, None, :]  # (E, 1 auxiliary, 2)
    track = SimpleNamespace(east_m=ref[:, 0] + 0.1, north_m=ref[:, 1])
    result = SimpleNamespace(
        inputs=SimpleNamespace(aux=["A1"], aux_en_m=aux, target="T"),
        reference_en_m=ref,
        tracks={"aacopf": track},
    )
    fig = Figure()
    ax = fig.add_subplot()
    plot_locate_trajectories(ax, result)  # type: ignore[arg-type]
    (aux_line,) = by_gid(ax, "aux_A1")
    assert aux_line.get_marker() == "D" and aux_line.get_label() == "Auxiliary A1"  # type: ignore[attr-defined]
    (start,) = by_gid(ax, "start")
    assert start.get_xydata().tolist() == [[0.0, 0.0]]  # type: ignore[attr-defined]
    (end,) = by_gid(ax, "end")
    assert end.get_xydata().tolist() == [[49.0, 24.5]]  # type: ignore[attr-defined]


def test_run_config_figure_style() -> None:
    from coopproc.errors import ConfigError
    from coopproc.run.config import RunConfig, run_config_from_toml

    assert RunConfig().run.figure_style == "default"
    config = run_config_from_toml({"run": {"figure_style": "double-column"}})
    assert config.run.figure_style == "double-column"
    with pytest.raises(ConfigError, match="figure_style"):
        run_config_from_toml({"run": {"figure_style": "ieee"}})


def test_stochastic_figures_follow_pairs_and_style(run: RunTables) -> None:
    from coopproc.report.stochastic import StochasticReport, uwb_stochastics
    from coopproc.report.stochastic_figures import stochastic_figures

    pairs, _ = uwb_stochastics(run.ranges)
    report = StochasticReport(tuple(pairs))

    def titles(fig: Figure) -> list[str]:
        return [ax.get_title(loc="left") for ax in fig.axes if ax.get_title(loc="left")]

    every = stochastic_figures(report)
    assert [t.split(":")[0] for t in titles(every["uwb_acf"])][-1] == "(d) all"
    chosen = FigureOptions(pairs=("B-C",), style=STYLES["single-column"])
    figs = stochastic_figures(report, chosen)
    assert set(figs) == {"uwb_acf", "uwb_pdf"}
    for fig in figs.values():
        assert [t[:7] for t in titles(fig)] == ["(a) B-C"]  # no other pair, no pooled 'all'
        assert fig.get_figwidth() == pytest.approx(3.5)
