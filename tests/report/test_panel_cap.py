"""The default cap on figure pages (--max-pages, [run] max_pages): which panels it keeps,
what it says it left out (notes, report.html), and that runs under the cap are unchanged."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner
from matplotlib.figure import Figure
from PIL import Image
from report_synth import make_run
from test_report_rundir import write_run_dir

import coopproc.report.html_figures as html_figures
from coopproc.cli import main
from coopproc.errors import ConfigError
from coopproc.report.figures import FigurePage, figure_pages
from coopproc.report.html import render_html
from coopproc.report.page_workers import page_workers, save_pages
from coopproc.report.pages import FigureOptions
from coopproc.report.panel_cap import cap_indices
from coopproc.report.run_tables import RunTables
from coopproc.report.style import MAX_PAGES
from coopproc.run.config import RunParams, run_config_from_toml


@pytest.fixture(scope="module")
def run() -> RunTables:
    # observed range RMSE: A-B 0.244, A-C 0.145, B-C 0.265 (metrics.csv of make_run)
    return make_run(n=80)


def pages_by_name(run: RunTables, opts: FigureOptions) -> dict[str, list[FigurePage]]:
    out: dict[str, list[FigurePage]] = {}
    for page in figure_pages(run, opts):
        out.setdefault(page.name, []).append(page)
    return out


def drawn(pages: list[FigurePage]) -> list[str]:
    return [key for page in pages for key in page.keys]


def test_cap_indices_keep_the_highest_in_their_order() -> None:
    scores = [1.0, math.nan, 3.0, 3.0, 2.0]
    assert cap_indices(scores, 2) == [2, 3]
    assert cap_indices(scores, 3) == [2, 3, 4]
    assert cap_indices([2.0, 5.0, 2.0, 1.0], 2) == [0, 1]  # a tie goes to the earlier
    assert cap_indices(scores, 4) == [0, 2, 3, 4]  # no score: last
    assert cap_indices(scores, 0) == [0, 1, 2, 3, 4]
    assert cap_indices(scores, 9) == [0, 1, 2, 3, 4]


def test_pair_figures_keep_the_pairs_of_largest_observed_rmse(run: RunTables) -> None:
    figures = pages_by_name(run, FigureOptions(max_panels=1, max_pages=2))
    # the two largest RMSE (B-C, A-B), in name order; A-C (the smallest) left out
    for name in ("distance_errors", "di_errors"):
        assert drawn(figures[name]) == ["A-B", "B-C"]
        assert [p.stem for p in figures[name]] == [name, f"{name}_2"]
        capped = figures[name][0].capped
        assert capped is not None and capped.left_out == ("A-C",)
        assert capped.note() == (
            f"{name}: drew 2 of 3 pairs (the 2 with the largest observed range RMSE; at "
            "most 2 pages of 1 panel); draw others with `coopproc report OUT --plots "
            "--pairs A-C`, or all with `--max-pages 0`."
        )
    figures = pages_by_name(run, FigureOptions(max_panels=1, max_pages=1))
    assert drawn(figures["distance_errors"]) == ["B-C"]
    # the labels run on over the panels drawn: (a), (b), not the skipped one's letter
    page = pages_by_name(run, FigureOptions(max_panels=2, max_pages=1))["distance_errors"][0]
    titles = [ax.get_title(loc="left") for ax in page.draw().axes]
    assert titles == ["(a) A-B", "(b) B-C"]


def test_platform_figures_rank_by_the_primary_methods_error(run: RunTables) -> None:
    metrics = run.position_metrics.copy()
    at = metrics["platform"] == "C"
    metrics.loc[at & (metrics["method"] == "di"), "rmse"] = 0.5  # C's DI error the larger
    metrics.loc[(metrics["platform"] == "A") & (metrics["method"] == "nav"), "rmse"] = 9.0
    run = dataclasses.replace(run, position_metrics=metrics)
    figures = pages_by_name(run, FigureOptions(max_panels=1, max_pages=1))
    # by the primary method (di), not the largest of any method (A's nav)
    assert drawn(figures["position_errors"]) == ["C"]
    assert drawn(figures["trajectories"]) == ["C"]
    capped = figures["trajectories"][0].capped
    assert capped is not None and capped.left_out == ("A", "B")
    assert "--platforms A,B`" in capped.note()


def test_event_figure_keeps_the_largest_estimates(run: RunTables) -> None:
    estimates = run.nlos_estimates
    assert estimates is not None
    big = estimates.copy()
    big.loc[big["pair"] == "A-B", "estimate"] *= 10.0
    figures = pages_by_name(
        dataclasses.replace(run, nlos_estimates=big), FigureOptions(max_panels=1, max_pages=1)
    )
    assert [k.split(",")[0] for k in drawn(figures["nlos_convergence"])] == ["A-B"]
    small = estimates.copy()
    small.loc[small["pair"] == "A-B", "estimate"] *= 0.1
    figures = pages_by_name(
        dataclasses.replace(run, nlos_estimates=small), FigureOptions(max_panels=1, max_pages=1)
    )
    assert [k.split(",")[0] for k in drawn(figures["nlos_convergence"])] == ["B-C"]
    capped = figures["nlos_convergence"][0].capped
    assert capped is not None and "--pairs A-B`" in capped.note()


def test_no_cap_when_chosen_or_zero_or_under_it(run: RunTables) -> None:
    everything = {n: drawn(p) for n, p in pages_by_name(run, FigureOptions(max_pages=0)).items()}
    assert everything["distance_errors"] == ["A-B", "A-C", "B-C"]
    # under the default cap: the same pages as without a cap, none capped
    default = pages_by_name(run, FigureOptions())
    assert {n: drawn(p) for n, p in default.items()} == everything
    assert all(p.capped is None for pages in default.values() for p in pages)
    # 0: all pages of one panel
    figures = pages_by_name(run, FigureOptions(max_panels=1, max_pages=0))
    assert len(figures["distance_errors"]) == 3
    # chosen pairs are drawn whole, whatever the cap
    chosen = FigureOptions(pairs=("A-B", "A-C", "B-C"), max_panels=1, max_pages=1)
    assert drawn(pages_by_name(run, chosen)["distance_errors"]) == ["A-B", "A-C", "B-C"]
    with pytest.raises(ConfigError, match="max pages"):
        FigureOptions(max_pages=-1)


def test_config_key_and_its_check() -> None:
    assert RunParams().max_pages == MAX_PAGES
    assert run_config_from_toml({"run": {"max_pages": 0}}).run.max_pages == 0
    with pytest.raises(ConfigError, match="max_pages must be >= 0"):
        run_config_from_toml({"run": {"max_pages": -1}})
    result = CliRunner().invoke(main, ["config"])
    assert result.exit_code == 0 and "\nmax_pages = 2\n" in result.output


def test_html_says_what_the_cap_left_out(
    run: RunTables, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(html_figures, "_render", lambda page: b"not drawn")  # no matplotlib
    page = render_html(tmp_path, run, options=FigureOptions(max_panels=1, max_pages=1))
    assert "distance_errors: drew 1 of 3 pairs (the 1 with the largest observed range" in page
    assert "<code>coopproc report OUT --plots --pairs A-B,A-C</code>" in page
    assert "Left out: A-B; A-C.</p>" in page
    assert "Left out: B-C, event 1" in page or "Left out: A-B, event 1" in page
    page = render_html(tmp_path, run, options=FigureOptions())
    assert "Left out" not in page


@pytest.mark.slow  # figure pages through the CLI
def test_cli_report_follows_the_runs_max_pages(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    run = make_run(n=80)
    info = {**run.info, "config": {"run": {"max_pages": 1}}}
    out = write_run_dir(dataclasses.replace(run, info=info), tmp_path / "out")
    args = ["report", str(out), "--max-panels", "1"]
    result = CliRunner().invoke(main, [*args, "--plots", "--dpi", "50"])
    assert result.exit_code == 0, result.output
    figures = out / "figures"
    assert not (figures / "distance_errors_2.png").exists()  # run.json: max_pages 1
    with Image.open(figures / "distance_errors.png") as image:
        assert image.info["Panels"] == "B-C"
    assert "note: distance_errors: drew 1 of 3 pairs" in result.output
    assert f"`coopproc report {out} --plots --pairs A-B,A-C`" in result.output
    # --max-pages 0: every page (listed in report.html; rendering stubbed)
    monkeypatch.setattr(html_figures, "_render", lambda page: b"not drawn")
    result = CliRunner().invoke(main, [*args, "--html", "--max-pages", "0"])
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text()
    assert "Left out" not in page and "3 panels on 3 pages of at most 1" in page
    assert json.loads((out / "run.json").read_text())["config"]["run"]["max_pages"] == 1


def _draw_page(page: tuple[Path, float]) -> list[Path]:
    """A small matplotlib page saved as PNG with the drawing process's id beside it."""
    path, slope = page
    fig = Figure(figsize=(2, 1.5))
    fig.subplots().plot([0.0, 1.0, 2.0], [0.0, slope, 2 * slope], label=f"{slope}")
    fig.legend()
    fig.savefig(path, dpi=40, metadata={"Software": None})
    path.with_suffix(".pid").write_text(str(os.getpid()))
    return [path]


def test_pages_drawn_in_workers_are_the_same_files(tmp_path: Path) -> None:
    def pages(where: str) -> list[tuple[Path, float]]:
        (tmp_path / where).mkdir()
        return [(tmp_path / where / f"p{i}.png", 0.5 * i) for i in range(4)]

    serial = save_pages(pages("a"), _draw_page, workers=1)
    forked = save_pages(pages("b"), _draw_page, workers=2, cost=lambda page: page[1])
    assert [p.name for p in forked] == [p.name for p in serial] == [f"p{i}.png" for i in range(4)]
    assert all(a.read_bytes() == b.read_bytes() for a, b in zip(serial, forked, strict=True))

    def pids(paths: list[Path]) -> set[int]:
        return {int(p.with_suffix(".pid").read_text()) for p in paths}

    assert pids(serial) == {os.getpid()} and os.getpid() not in pids(forked)
    # off the main thread (coopproc batch's threaded Dask workers): drawn in the caller
    found: list[int] = []
    worker = threading.Thread(target=lambda: found.append(page_workers()))
    worker.start()
    worker.join()
    assert found == [1]
