"""What a figure draws is bounded by its pixels, not by the session's length (issue 11)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from coopproc.report.decimate import decimate, panel_points
from coopproc.report.evaluation_plots import _cdf_points, plot_error_cdf
from coopproc.report.gaps import NO_REFERENCE_SPAN, GapSpans, shade_gaps, shaded_spans
from coopproc.report.panels import groups
from coopproc.report.plots import plot_position_errors
from coopproc.report.style import DRAWN_DPI, MAX_LINE_POINTS
from coopproc.report.trajectory_plots import _first_per_time, _rows_at


def _platform(hours: float, spike_at: float) -> pd.DataFrame:
    """One platform's di and rn rows at 10 Hz, a one-epoch spike of di at ``spike_at``."""
    t = 0.1 * np.arange(int(hours * 36_000))
    wave = 0.2 + 0.05 * np.sin(t / 30.0)
    di = wave.copy()
    di[np.searchsorted(t, spike_at)] = 9.0
    frames = [
        pd.DataFrame({"time": t, "platform": "A", "method": m, "error_h": e})
        for m, e in (("di", di), ("rn", wave + 0.1))
    ]
    return pd.concat(frames, ignore_index=True)


def _drawn(rows: pd.DataFrame | dict[str, pd.DataFrame], width_in: float) -> dict[str, np.ndarray]:
    ax = Figure(figsize=(width_in, 2.0)).subplots()
    plot_position_errors(ax, rows, methods=["rn", "di"])
    return {str(ln.get_gid()): np.asarray(ln.get_ydata(), float) for ln in ax.get_lines()}


def test_a_line_draws_two_points_a_pixel_column_whatever_the_session_length() -> None:
    ax = Figure(figsize=(3.0, 2.0)).subplots()
    cap = panel_points(ax)
    width_px = ax.get_position().width * 3.0 * DRAWN_DPI
    assert 2 * width_px <= cap <= 2 * width_px + 2 and cap < MAX_LINE_POINTS
    hour, day = _drawn(_platform(1.0, 1234.5), 3.0), _drawn(_platform(6.0, 20_000.0), 3.0)
    for drawn in (hour, day):
        assert drawn["di"].size <= cap + 2 and drawn["rn"].size <= cap + 2
        assert np.nanmax(drawn["di"]) == 9.0  # the one-epoch spike at full height
    # a wider panel shows more, up to the cap of the widest
    assert _drawn(_platform(1.0, 1234.5), 7.0)["di"].size > hour["di"].size


def test_rows_per_method_draw_what_the_rows_draw() -> None:
    rows = _platform(0.5, 600.0)
    as_rows, as_groups = _drawn(rows, 3.0), _drawn(groups(rows, "method"), 3.0)
    assert as_rows.keys() == as_groups.keys()
    for key, y in as_rows.items():
        np.testing.assert_array_equal(y, as_groups[key])


def test_a_day_of_spans_is_one_path_per_kind_and_every_span_stays() -> None:
    # a day of short no-reference spans 2 s apart (under a pixel), one lone 0.5 s outage
    starts = np.arange(0.0, 20_000.0, 5.0)
    many = np.column_stack([starts, starts + 3.0])
    lone = np.array([[60_000.0, 60_000.5]])
    ax = Figure().subplots()
    ax.plot([0.0, 86_400.0], [0.0, 1.0])
    shade_gaps(ax, GapSpans(lone, many))
    # not joined: spans a pixel apart stay apart
    assert shaded_spans(ax, "no_reference").tolist() == many.tolist()
    assert shaded_spans(ax, "uwb_outage").tolist() == lone.tolist()
    shades = [c for c in ax.collections if c.get_gid() == "no_reference"]
    assert len(shades) == 1 and len(shades[0].get_paths()) == 1  # one hatched path


def _pixels(draw: Callable[[Axes], None]) -> np.ndarray:
    fig = Figure(figsize=(2.3, 1.5), dpi=300)
    ax = fig.subplots()
    ax.plot([0.0, 86_400.0], [0.0, 1.0], linewidth=0.0)
    draw(ax)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba(), dtype=np.float64)[..., :3]


def test_one_path_of_spans_has_the_pixels_of_one_span_at_a_time() -> None:
    rng = np.random.default_rng(1)
    starts = np.sort(rng.uniform(0.0, 86_400.0, 250))  # 1 to 60 s wide: mostly sub-pixel
    spans = np.column_stack([starts, starts + rng.uniform(1.0, 60.0, starts.size)])
    spans = spans[np.concatenate([[True], spans[1:, 0] > spans[:-1, 1]])]

    def one_by_one(ax: Axes) -> None:
        for start, end in spans:
            ax.axvspan(start, end, **NO_REFERENCE_SPAN)

    old = _pixels(one_by_one)
    new = _pixels(lambda ax: shade_gaps(ax, GapSpans(spans[:0], spans)))
    assert (old < 250).any(axis=2).sum() > 500  # the spans show
    assert (np.abs(old - new) > 0).any(axis=2).mean() < 0.002


def test_cdf_points_are_the_envelope_of_the_exact_curve() -> None:
    rng = np.random.default_rng(5)
    for n in (10, MAX_LINE_POINTS - 1, 123_457):
        h = np.sort(rng.gamma(2.0, 0.1, n))
        x, y = _cdf_points(h)
        # what decimating the whole curve gives, point for point
        full_x = np.concatenate([[0.0], h])
        full_y = np.concatenate([[0.0], np.arange(1, n + 1, dtype=np.float64) / n])
        old_x, old_y = decimate(full_x, full_y)
        np.testing.assert_array_equal(x, old_x)
        np.testing.assert_array_equal(y, old_y)
        assert x[-1] == h[-1] and y[-1] == 1.0 and x.size <= MAX_LINE_POINTS + 2
    rows = pd.DataFrame({"method": "di", "error_h": rng.gamma(2.0, 0.1, 200_000)})
    ax = Figure().subplots()
    plot_error_cdf(ax, rows)
    (line,) = ax.get_lines()[:1]
    assert np.asarray(line.get_xdata()).size <= MAX_LINE_POINTS + 2


def test_zoom_epochs_found_by_binary_search() -> None:
    rows = pd.DataFrame(
        {
            "time": [1.0, 2.0, 2.0, 4.0, 7.0],
            "east": [10.0, 20.0, 21.0, 40.0, 70.0],
            "north": [0.0, 1.0, 2.0, 3.0, 4.0],
        }
    )
    t, east, north = _first_per_time(rows)
    assert t.tolist() == [1.0, 2.0, 4.0, 7.0] and east.tolist() == [10.0, 20.0, 40.0, 70.0]
    assert north.tolist() == [0.0, 1.0, 3.0, 4.0]
    assert _rows_at(t, np.array([0.5, 2.0, 7.0, 8.0, 4.0])).tolist() == [-1, 1, 3, -1, 2]
    assert _rows_at(t[:0], np.array([1.0])).tolist() == [-1]
