"""The evaluation figures (error CDF, error-coloured track) and the report.html section,
on the shared synthetic run (report_synth.py: platforms A and C have a horizontal error,
B has none)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from report_synth import make_run

from coopproc.report.figures import FIGURE_NAMES, error_cdf_figure, error_track_figure
from coopproc.report.html import render_html
from coopproc.report.run_tables import RunTables


@pytest.fixture(scope="module")
def run() -> RunTables:
    return make_run()


def _rows(run: RunTables, platform: str, method: str):  # type: ignore[no-untyped-def]
    pos = run.positions
    rows = pos[(pos["platform"] == platform) & (pos["method"] == method)]
    return rows[rows["error_h"].notna()].sort_values("time")


def test_error_cdf_steps_through_every_error(run: RunTables) -> None:
    fig = error_cdf_figure(run)
    assert fig is not None
    axes = [ax for ax in fig.axes if ax.get_title(loc="left")]
    assert [ax.get_title(loc="left") for ax in axes] == ["(a) Platform A", "(b) Platform C"]
    for ax, platform in zip(axes, "AC", strict=True):
        lines = {ln.get_gid(): ln for ln in ax.get_lines() if ln.get_gid()}
        assert list(lines) == ["nav", "observed", "rn", "di"]  # own nav first, then the run's
        for method, line in lines.items():
            h = _rows(run, platform, method)["error_h"].to_numpy()
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            np.testing.assert_allclose(x[1:], np.sort(h))
            np.testing.assert_allclose(y, np.arange(h.size + 1) / h.size)
            # the median read off the curve is CEP50 (between the two middle errors)
            assert np.sort(h)[np.searchsorted(y[1:], 0.5)] <= np.percentile(h, 50) + 1e-12


def test_error_track_colours_each_epoch_by_its_error(run: RunTables) -> None:
    fig = error_track_figure(run)
    assert fig is not None
    panels = [ax for ax in fig.axes if ax.get_title(loc="left")]
    assert len(panels) == 2 and len(fig.axes) == 3  # + the shared colour bar
    both = np.concatenate([_rows(run, p, "di")["error_h"].to_numpy() for p in "AC"])
    for ax, platform in zip(panels, "AC", strict=True):
        (dots,) = [c for c in ax.collections if c.get_gid() == "di"]  # the primary method
        rows = _rows(run, platform, "di")
        np.testing.assert_allclose(dots.get_offsets(), rows[["east", "north"]].to_numpy())
        np.testing.assert_allclose(dots.get_array(), rows["error_h"].to_numpy())
        assert dots.norm.vmin == 0.0
        assert dots.norm.vmax == pytest.approx(np.percentile(both, 95))
        (ref,) = [ln for ln in ax.get_lines() if ln.get_gid() == "reference"]
        assert len(ref.get_xdata()) == int(
            (
                (run.positions["platform"] == platform) & (run.positions["method"] == "reference")
            ).sum()
        )


def test_html_has_the_evaluation_section_and_figures(run: RunTables, tmp_path: Path) -> None:
    (tmp_path / "figures").mkdir()
    for name in FIGURE_NAMES:  # figure files are embedded as they are (no rendering here)
        (tmp_path / "figures" / f"{name}.png").write_bytes(b"png")
    page = render_html(tmp_path, run)
    assert "<h2>Evaluation</h2>" in page
    assert "Trajectory errors per platform and method, alignment none" in page
    assert "Relative error over 50 m of travel, alignment none" in page
    assert 'id="fig-error_cdf"' in page and 'id="fig-error_track"' in page
    assert page.index("<h2>Evaluation</h2>") < page.index("<h2>Figures</h2>")
