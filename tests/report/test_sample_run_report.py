"""A run of sample_logs: every NLOS event with estimates is in the convergence figure, and
the report.html of the run reads as a page (notes, method names, no figures when asked)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.report.convergence import convergence_panels
from coopproc.report.figures import figure_pages
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run
from coopproc.report.style import RC

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not SAMPLE.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    out = tmp_path_factory.mktemp("sample") / "run"
    result = CliRunner().invoke(main, ["run", str(SAMPLE), "-o", str(out), "--no-figures", "-q"])
    assert result.exit_code == 0, result.output
    return out


def _expected_events(run: RunTables) -> list[tuple[str, str, tuple[float, ...]]]:
    """(pair, method, estimates in step order) of every nlos_events row whose span holds
    estimates of its pair and method."""
    assert run.nlos_estimates is not None
    est = run.nlos_estimates
    out = []
    for ev in run.nlos_events.itertuples():
        rows = est[
            (est["pair"] == ev.pair)
            & (est["method"] == ev.method)
            & (est["time"] >= ev.start)
            & (est["time"] <= ev.end)
        ]
        if len(rows):
            values = rows.sort_values("step")["estimate"].to_numpy(dtype=float)
            out.append((str(ev.pair), str(ev.method), tuple(np.round(values, 6))))
    return out


def test_every_event_with_estimates_is_a_series(sample_run: Path) -> None:
    """sample_logs has RN-Based events outside the DI events' estimation steps (B-C at
    t = 485 s lies in DI event 2's span, 15 s after its last step): matched by the steps'
    times it was dropped; by the events' spans it is drawn."""
    run = load_run(sample_run)
    expected = _expected_events(run)
    methods = {m for _, m, _ in expected}
    assert methods == {"di", "rn"}
    assert len(expected) == 8  # 4 DI, 4 RN
    with mpl.rc_context(RC):
        figs = [p.draw() for p in figure_pages(run) if p.name == "nlos_convergence"]
    drawn = []
    for fig in figs:
        for ax in fig.axes:
            pair = ax.get_title(loc="left").split()[1].rstrip(",")
            for line in ax.get_lines():
                if line.get_gid() in methods:
                    values = np.round(np.asarray(line.get_ydata(), dtype=float), 6)
                    drawn.append((pair, str(line.get_gid()), tuple(values)))
    assert sorted(drawn) == sorted(expected)


def test_an_event_beside_the_primary_ones_gets_its_own_panel(sample_run: Path) -> None:
    """Each RN event inside a DI span joins the DI panel; an RN event overlapping no DI
    event has a panel of its own."""
    run = load_run(sample_run)
    titles = [title for title, _, _ in convergence_panels(run)]
    assert titles == [
        "A-B, event 1 (t = 120 s)",
        "A-B, event 2 (t = 381 s)",
        "B-C, event 1 (t = 230 s)",
        "B-C, event 2 (t = 470 s)",
    ]
    assert run.nlos_estimates is not None
    lone = run.nlos_estimates.iloc[[0]].assign(
        pair="A-B", method="rn", event=9, step=1, time=run.nlos_events["start"].min() - 50.0
    )
    moved = RunTables(
        **{**vars(run), "nlos_estimates": pd.concat([run.nlos_estimates, lone], ignore_index=True)}
    )
    panels = convergence_panels(moved)
    assert panels[0][0].startswith("A-B, RN-Based event 9 (t = 70 s)")
    assert set(panels[0][1]["method"]) == {"rn"} and len(panels) == 5


def test_no_figures_still_writes_the_page(sample_run: Path) -> None:
    """`coopproc run --no-figures`: no figures/, but report.html with the tables, no image
    and a Figures section saying why."""
    assert not (sample_run / "figures").exists()
    page = (sample_run / "report.html").read_text(encoding="utf-8")
    assert "<caption>Table 3. Horizontal position errors per platform and method</caption>" in (
        page
    )
    assert "<img" not in page and "data:image/png" not in page
    assert "No figures: the run was made without them" in page
    assert re.search(r"<li>[^<]*ref_A\.pos: 101 of 3001 epochs", page)  # the run's notes


def test_gaps_are_computed_when_a_page_draws_them_once_per_run(
    sample_run: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Listing the pages (report.html does, to match the figure files) computes no shaded
    spans; the distance and DI figures share the pairs' spans (computed once)."""
    import coopproc.report.figure_builders as figures

    calls: list[str] = []
    for name in ("pair_gaps", "method_gaps"):
        real = getattr(figures, name)
        monkeypatch.setattr(
            figures,
            name,
            lambda rows, *nav, real=real, name=name: calls.append(name) or real(rows, *nav),
        )
    run = load_run(sample_run)
    pages = list(figure_pages(run))
    assert {"distance_errors", "di_errors", "position_errors"} <= {p.name for p in pages}
    assert calls == []
    with mpl.rc_context(RC):
        for page in pages:
            if page.name in ("distance_errors", "di_errors"):
                page.draw()
    assert calls == ["pair_gaps"]


def test_dr_states_figure_has_two_panels_per_follower(sample_run: Path) -> None:
    """figures/dr_states.png: per follower its DR heading error and its odometer scale error,
    one line per fusion method; the leader (no DR states) has none."""
    from coopproc.report.dr_states_figure import dr_states_panels
    from coopproc.report.pages import FigureOptions

    run = load_run(sample_run)
    assert run.dr_states is not None
    assert set(run.dr_states["platform"]) == {"A", "C"}
    assert set(run.dr_states["method"]) == {"observed", "rn", "di"}
    panels = dr_states_panels(run, FigureOptions())
    assert panels is not None
    assert list(panels.keys) == [
        "A:heading_error",
        "A:scale_error",
        "C:heading_error",
        "C:scale_error",
    ]
    with mpl.rc_context(RC):
        fig = panels.page(range(len(panels.keys)))
    axes = fig.get_axes()
    assert len(axes) == 4
    assert len(axes[0].get_lines()) == 4  # three methods and the zero line
    # the scale panel in percent: the simulator's A reads 0.36 % short
    observed = run.dr_states[(run.dr_states["platform"] == "A") & (run.dr_states["method"] == "di")]
    assert float(observed["scale_error"].median()) == pytest.approx(-0.0036, abs=0.002)
    ydata = axes[1].get_lines()[0].get_ydata()  # DI-Based, the first method in name order
    assert float(np.median(ydata)) == pytest.approx(100 * float(observed["scale_error"].median()))
    fig.clear()


def test_dr_states_figure_marks_the_jumps_the_observed_fusion_found(sample_run: Path) -> None:
    """A jump in run.json's calibration.fusion.observed.dr_jumps is a dotted vertical line
    in both of its platform's panels (sample_logs has none: two are put in)."""
    import dataclasses

    from coopproc.report.dr_states_figure import dr_states_panels
    from coopproc.report.pages import FigureOptions

    run = load_run(sample_run)
    t0 = run.time_origin_s
    info = dict(run.info)
    calibration = dict(info.get("calibration", {}))
    fusion = dict(calibration.get("fusion", {}))
    fusion["observed"] = dict(fusion.get("observed", {})) | {
        "dr_jumps": [
            {"platform": "C", "time": t0 + 100.0, "size_m": 0.4},
            {"platform": "C", "time": t0 + 250.0, "size_m": 0.3},
        ]
    }
    fusion["di"] = dict(fusion.get("di", {})) | {
        "dr_jumps": [{"platform": "A", "time": t0 + 50.0, "size_m": 0.2}]  # not drawn
    }
    run = dataclasses.replace(run, info=info | {"calibration": calibration | {"fusion": fusion}})
    panels = dr_states_panels(run, FigureOptions())
    assert panels is not None
    with mpl.rc_context(RC):
        fig = panels.page(range(len(panels.keys)))
    axes = fig.get_axes()

    def vertical(ax: object) -> list[float]:
        return sorted(
            float(line.get_xdata()[0])
            for line in ax.get_lines()  # type: ignore[attr-defined]
            if line.get_linestyle() == ":"
        )

    assert vertical(axes[0]) == [] and vertical(axes[1]) == []  # A: the observed found none
    assert vertical(axes[2]) == pytest.approx([100.0, 250.0])
    assert vertical(axes[3]) == pytest.approx([100.0, 250.0])
    fig.clear()
