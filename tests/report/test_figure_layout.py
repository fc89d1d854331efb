"""Figure layout read back from the drawn artists: panel titles inside the figure and clear
of the other panels and of the legend (``--style single-column`` NLOS convergence, the
trajectories of 10 platforms on a fixed-margin grid); the run's outage windows marked in
the distance and position error figures."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox
from report_synth import T0, make_run

from coopproc.model import POSITIONS_COLUMNS
from coopproc.report.figures import (
    distance_errors_figure,
    nlos_convergence_figure,
    position_errors_figure,
    trajectories_figure,
)
from coopproc.report.gaps import shaded_spans
from coopproc.report.pages import FigureOptions
from coopproc.report.run_tables import RunTables
from coopproc.report.style import STYLES


def _titles(fig: Figure) -> list[tuple[Axes, Text]]:
    # the panels' titles are left titles: Axes.get_title(loc="left") has the text only
    return [(ax, ax._left_title) for ax in fig.axes if ax.get_title(loc="left")]


def _layout_faults(fig: Figure) -> list[str]:
    """What a reviewer would send back: a title outside the figure, or overlapping
    another panel (its frame, tick labels, axis labels, title) or a legend."""
    fig.draw_without_rendering()  # the layout as saved
    renderer = FigureCanvasAgg(fig).get_renderer()
    frame = fig.bbox
    panels = [(ax, ax.get_tightbbox(renderer)) for ax in fig.axes]
    faults = []
    for ax, title in _titles(fig):
        box = title.get_window_extent(renderer)
        name = title.get_text().replace("\n", " ")
        if not (box.x0 >= frame.x0 and box.x1 <= frame.x1 and box.y1 <= frame.y1):
            faults.append(f"{name}: outside the figure")
        for other, other_box in panels:
            if other is not ax and box.overlaps(other_box):
                faults.append(f"{name}: overlaps panel {other.get_title(loc='left')!r}")
        for legend in fig.legends:
            if box.overlaps(Bbox(legend.get_window_extent(renderer))):
                faults.append(f"{name}: overlaps the legend")
    return faults


@pytest.fixture(scope="module")
def run() -> RunTables:
    return make_run(n=80)


def test_single_column_convergence_titles_are_broken_not_cut(run: RunTables) -> None:
    options = FigureOptions(style=STYLES["single-column"])
    fig = nlos_convergence_figure(run, options)
    assert fig is not None
    texts = [t.get_text() for _, t in _titles(fig)]
    # two panels a row in 3.5 in: "(a) A-B, event 1 (t = 30 s)" is 1.5 in of 8 pt text
    assert texts == ["(a) A-B, event 1\n(t = 30 s)", "(b) B-C, event 1\n(t = 50 s)"]
    assert _layout_faults(fig) == []
    # the default style has the room (7 in wide): one line, and clear too
    default = nlos_convergence_figure(run)
    assert default is not None
    assert [t.get_text() for _, t in _titles(default)] == [
        "(a) A-B, event 1 (t = 30 s)",
        "(b) B-C, event 1 (t = 50 s)",
    ]
    assert _layout_faults(default) == []


def _ten_platforms(run: RunTables, n: int = 40) -> RunTables:
    """10 platforms with a reference, own nav and three methods (7 legend entries with
    start and end: three legend rows), a short straight track each."""
    t = T0 + np.arange(n, dtype=float)
    rows = []
    for j in range(10):
        east, north = 0.5 * (t - T0) + j, 0.2 * (t - T0) + 3.0 * j
        for k, method in enumerate(("reference", "nav", "observed", "rn", "di")):
            off = 0.05 * k
            rows.append(
                pd.DataFrame(
                    {
                        "time": t,
                        "platform": f"P{j:02d}",
                        "method": method,
                        "east": east + off,
                        "north": north - off,
                        "up": 0.0,
                        "error_h": np.nan if method == "reference" else off,
                    }
                )
            )
    positions = pd.concat(rows, ignore_index=True)[list(POSITIONS_COLUMNS)]
    return dataclasses.replace(run, positions=positions)


def test_ten_platforms_legend_clear_of_the_titles(run: RunTables) -> None:
    fig = trajectories_figure(_ten_platforms(run))
    assert fig is not None
    assert len(_titles(fig)) == 10 and fig.get_layout_engine() is None  # fixed margins
    (legend,) = fig.legends
    assert len(legend.get_texts()) == 7
    assert _layout_faults(fig) == []
    # the panels keep their size: the figure grew by what the third legend row needs
    width, height = fig.get_size_inches()
    assert width == 7.0 and 0.62 + 0.5 + 4 * 2.3 + 0.05 < height < 0.62 + 0.5 + 4 * 2.3 + 0.4
    panel = fig.axes[0].get_position()
    assert panel.height * height == pytest.approx(fig.axes[-1].get_position().height * height)


def test_outage_windows_are_marked_in_the_error_figures(run: RunTables) -> None:
    window = {"start_s": 10.0, "end_s": 22.5, "start": T0 + 10.0, "end": T0 + 22.5}
    info = {**run.info, "outages": {"windows": [window], "withheld": 30, "positions_at": "nav"}}
    windowed = dataclasses.replace(run, info=info)
    for make in (distance_errors_figure, position_errors_figure):
        fig = make(windowed)
        assert fig is not None
        for ax in fig.axes:  # every panel, in times since t0 (= T0)
            assert shaded_spans(ax, "outage_window").tolist() == [[10.0, 22.5]]
        labels = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        assert labels.count("Outage window") == 1
    plain = position_errors_figure(run)  # a run without windows: none
    assert plain is not None and shaded_spans(plain.axes[0], "outage_window").size == 0
