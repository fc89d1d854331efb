"""Figure pages, panel labels, --pairs / --platforms / --max-panels and the HTML that links
large figures instead of embedding them."""

from __future__ import annotations

import base64
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from PIL import Image
from report_synth import make_run
from test_report_rundir import write_run_dir

import coopproc.report.html_figures as html_figures
from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.report.figures import make_figures, write_figures
from coopproc.report.html import render_html
from coopproc.report.pages import (
    FigureOptions,
    check_selection,
    page_ranges,
    page_stem,
    panel_letter,
)
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_run_dir(make_run(n=80), tmp_path_factory.mktemp("pages") / "out")


@pytest.fixture(scope="module")
def run(out_dir: Path) -> RunTables:
    return load_run(out_dir)


def panels_of(path: Path) -> str:
    with Image.open(path) as image:
        return str(image.info["Panels"])


def titles(fig: object) -> list[str]:
    return [ax.get_title(loc="left") for ax in fig.axes if ax.get_title(loc="left")]  # type: ignore[attr-defined]


def test_panel_letters_continue_past_z() -> None:
    letters = [panel_letter(i) for i in (0, 1, 25, 26, 27, 51, 52, 701, 702)]
    assert letters == ["a", "b", "z", "aa", "ab", "az", "ba", "zz", "aaa"]
    with pytest.raises(ValueError):
        panel_letter(-1)


def test_page_names_and_ranges() -> None:
    assert [page_stem("distance_errors", i) for i in range(3)] == [
        "distance_errors",
        "distance_errors_2",
        "distance_errors_3",
    ]
    assert [list(r) for r in page_ranges(5, 2)] == [[0, 1], [2, 3], [4]]
    assert page_ranges(0, 24) == []
    with pytest.raises(ConfigError):
        FigureOptions(max_panels=0)


@pytest.mark.slow
def test_pages_of_one_panel_keep_labels_running(run: RunTables, tmp_path: Path) -> None:
    figs = make_figures(run, FigureOptions(max_panels=1, max_pages=0))  # 0: no page cap
    assert titles(figs["distance_errors"]) == ["(a) A-B"]
    assert titles(figs["distance_errors_2"]) == ["(b) A-C"]
    assert titles(figs["distance_errors_3"]) == ["(c) B-C"]
    assert "distance_errors_4" not in figs
    written = write_figures(run, tmp_path, options=FigureOptions(max_panels=2), dpi=30)
    names = [p.name for p in written]
    assert names[:2] == ["distance_errors.png", "distance_errors_2.png"]
    assert panels_of(tmp_path / "distance_errors.png") == "A-B; A-C"
    assert panels_of(tmp_path / "distance_errors_2.png") == "B-C"
    # a later call with fewer pages removes the pages it no longer writes
    write_figures(run, tmp_path, dpi=30)
    assert not (tmp_path / "distance_errors_2.png").exists()
    assert panels_of(tmp_path / "distance_errors.png") == "A-B; A-C; B-C"


def test_selection_of_pairs_and_platforms(run: RunTables) -> None:
    opts = check_selection(run, pairs=["B-A"])  # the pair A-B, either order
    assert opts.pairs == ("A-B",)
    figs = make_figures(run, opts)
    assert titles(figs["distance_errors"]) == ["(a) A-B"]
    # --pairs alone keeps the platforms of those pairs (positions exist for A and C)
    assert titles(figs["position_errors"]) == ["(a) Platform A"]
    figs = make_figures(run, check_selection(run, platforms=["A", "C"]))
    assert titles(figs["distance_errors"]) == ["(a) A-C"]  # both ends chosen
    assert titles(figs["position_errors"]) == ["(a) Platform A", "(b) Platform C"]
    with pytest.raises(ConfigError, match=r"^unknown pair 'A-Z'; the run has A-B, A-C, B-C$"):
        check_selection(run, pairs=["A-Z"])
    with pytest.raises(ConfigError, match=r"unknown platform 'Q'; the run has A, B, C$"):
        check_selection(run, platforms=["Q"])


@pytest.mark.slow
def test_cli_report_plots_follow_pairs_and_max_panels(tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    runner = CliRunner()
    result = runner.invoke(main, ["report", str(out), "--plots", "--pairs", "B-C", "--dpi", "50"])
    assert result.exit_code == 0, result.output
    assert panels_of(out / "figures" / "distance_errors.png") == "B-C"
    result = runner.invoke(
        main,
        ["report", str(out), "--plots", "--max-panels", "1", "--max-pages", "0", "--dpi", "50"],
    )
    assert result.exit_code == 0, result.output
    assert panels_of(out / "figures" / "distance_errors_3.png") == "B-C"
    result = runner.invoke(main, ["report", str(out), "--plots", "--pairs", "A-Z"])
    assert result.exit_code != 0
    assert result.output.strip().splitlines() == [
        "error: unknown pair 'A-Z'; the run has A-B, A-C, B-C"
    ]


def test_cli_run_checks_pairs_before_the_work(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        main, ["run", str(REPO / "sample_logs"), "-o", str(tmp_path / "o"), "--platforms", "A,Q"]
    )
    assert result.exit_code != 0
    assert result.output.strip().splitlines()[-1] == (
        "error: unknown platform 'Q'; the run has A, B, C"
    )
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_html_embeds_small_figures_and_says_what_it_selected(
    run: RunTables, tmp_path: Path
) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    write_figures(load_run(out), out / "figures", dpi=30)
    page = render_html(out, load_run(out), options=FigureOptions(pairs=("A-B",)))
    assert "The figures show 1 of the run&#x27;s 3 pairs (A-B)" in page
    images = dict(re.findall(r'<img alt="(\w+)" src="data:image/png;base64,([^"]+)"', page))
    # the files hold all three pairs: the page renders the chosen pair instead
    distance = base64.b64decode(images["distance_errors"])
    assert distance != (out / "figures" / "distance_errors.png").read_bytes()
    assert "href=" not in page


@pytest.mark.slow
def test_html_links_large_figures(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    out = write_run_dir(make_run(n=80), tmp_path / "out")
    run = load_run(out)
    opts = FigureOptions(max_panels=2)
    write_figures(run, out / "figures", dpi=60, options=opts)
    files = sorted((out / "figures").glob("*.png"))
    total = sum(p.stat().st_size for p in files)
    monkeypatch.setattr(html_figures, "EMBED_LIMIT_BYTES", total // 2)
    monkeypatch.setattr(html_figures, "THUMBNAIL_WIDTH_PX", 100)
    page = render_html(out, run, options=opts)
    assert "The figure files are linked, not embedded" in page
    # the first page of each figure as a small copy linking to its file, further pages linked
    assert '<a href="figures/distance_errors.png"><img alt="distance_errors"' in page
    assert '<a href="figures/distance_errors_2.png">figures/distance_errors_2.png</a>' in page
    assert "3 panels on 2 pages of at most 2" in page
    assert "panels (c): B-C" in page
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) == len({p.stem.rsplit("_2", 1)[0] for p in files})  # one per figure
    for data in images:
        with Image.open(__import__("io").BytesIO(base64.b64decode(data))) as image:
            assert image.width <= 100
    assert len(page.encode()) < total
