"""The figures' gap rule, line breaks (also after decimation) and shaded spans."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from coopproc.model import gap_limit_s
from coopproc.report.gaps import (
    GapSpans,
    break_gaps,
    gap_spans,
    line_gap_limit_s,
    method_gaps,
    platform_gaps,
    series_gaps,
    shade_gaps,
    shaded_spans,
    typical_step_s,
)
from coopproc.report.plots import plot_nlos_convergence, plot_position_errors
from coopproc.report.style import MAX_LINE_POINTS


def bursts(n_cycles: int, offsets: tuple[float, ...] = (0.013, 0.034)) -> np.ndarray:
    """A platform's epochs: the ranges of its pairs, a few ms apart, once a second."""
    return (np.arange(n_cycles)[:, None] + np.array(offsets)[None, :]).ravel()


def test_limit_is_the_typical_step_not_the_burst_step() -> None:
    regular = np.arange(600.0)
    assert line_gap_limit_s(regular) == pytest.approx(2.5)
    three_pairs = bursts(600, (0.013, 0.034, 0.055))
    # the median step is the 21 ms inside a burst: 2.5 x it would cut every second
    assert gap_limit_s(three_pairs) == pytest.approx(2.5 * 0.021)
    assert line_gap_limit_s(three_pairs) == pytest.approx(2.5 * 0.958)
    assert not np.isnan(break_gaps(three_pairs, three_pairs)[1]).any()
    # order and repeats do not matter; one time is no series
    assert line_gap_limit_s(np.concatenate([regular, regular])[::-1]) == pytest.approx(2.5)
    assert line_gap_limit_s(np.array([5.0, 5.0])) == np.inf


def leader_epochs(hole: tuple[float, float] | None = None) -> np.ndarray:
    """A leader's epochs at 20 platforms: its 19 pairs polled in one burst within 0.1 s
    each second (a few ms jitter) for an hour, none in ``hole``."""
    rng = np.random.default_rng(11)
    offsets = np.linspace(0.0, 0.09, 19) + rng.uniform(0.0, 0.004, (3600, 19))
    t = (np.arange(3600.0)[:, None] + offsets).ravel()
    return t if hole is None else t[(t < hole[0]) | (t > hole[1])]


def test_a_burst_a_second_is_no_gap() -> None:
    t = leader_epochs()
    # one step in 19 is the pause between bursts: the 90th percentile is a 5 ms step
    assert np.percentile(np.diff(t), 90) < 0.01
    assert 0.85 < typical_step_s(t) < 0.92  # the pause, which carries 90 % of the time
    assert gap_spans(t, bounds=(0.0, 3600.0)).shape == (0, 2)
    assert not np.isnan(break_gaps(t, t)[1]).any()
    one_missed = leader_epochs((1000.0, 1000.99))  # a burst lost: a 1.9 s step, no gap
    assert gap_spans(one_missed).shape == (0, 2)


def test_a_hole_in_the_bursts_is_exactly_one_gap() -> None:
    t = leader_epochs((1000.0, 1004.99))  # bursts 1000..1004 missing: 5 s without ranges
    spans = gap_spans(t, bounds=(0.0, 3600.0))
    assert spans.shape == (1, 2)
    assert 999.09 < spans[0, 0] < 999.1 and 1005.0 <= spans[0, 1] < 1005.01
    x, _ = break_gaps(t, t)
    assert np.flatnonzero(np.isnan(x)).size == 1
    # and on a platform's panel: an outage there, a reference missing for 11 s elsewhere
    has = (t < 2000.0) | (t > 2011.0)
    gaps = series_gaps(t, has, bounds=(0.0, 3600.0))
    assert gaps.outages.tolist() == spans.tolist()
    assert gaps.no_reference.shape == (1, 2)
    assert gaps.no_reference[0, 0] > 1999.09 and gaps.no_reference[0, 1] < 2012.0


def test_staggered_pairs_keep_the_limit_of_their_step() -> None:
    """19 pairs at 1 Hz spread over the second: one step of 1/19 s; a 3 s hole is a gap."""
    t = (np.arange(600.0)[:, None] + np.arange(19)[None, :] / 19.0).ravel()
    assert line_gap_limit_s(t) == pytest.approx(2.5 / 19.0)
    holed = t[(t < 300.0) | (t > 303.0)]
    assert gap_spans(holed).ravel() == pytest.approx([300.0 - 1 / 19.0, 303.0 + 1 / 19.0])


def test_pairs_in_groups_a_missed_range_between_pauses_is_no_gap() -> None:
    """A platform whose 19 pairs range in a burst and two single slots a second (pauses of
    0.2, 0.2 and 0.44 s: the 90th percentile step is 0.2 s), 2 % of its ranges missed: a
    missed single slot joins two pauses (0.64 s), no outage; a 3 s hole is one."""
    offsets = np.concatenate([np.arange(17) * 0.01, [0.36, 0.56]])
    t = (np.arange(3600.0)[:, None] + offsets).ravel()
    t = t[np.random.default_rng(5).uniform(size=t.size) > 0.02]
    assert np.percentile(np.diff(t), 90) == pytest.approx(0.2, abs=0.01)
    assert typical_step_s(t) == pytest.approx(0.44, abs=0.01)
    assert gap_spans(t).shape == (0, 2)
    holed = t[(t < 1800.0) | (t > 1803.0)]
    assert gap_spans(holed).shape == (1, 2)


def test_irregular_steps_keep_the_percentile_limit_and_show_an_outage() -> None:
    """Real-ish steps: 0.135 s with jitter, dropped samples (2, 3 steps), a 4 s outage; the
    limit is the old one, 2.5 x the 90th percentile, and only the outage is a gap."""
    rng = np.random.default_rng(3)
    steps = 0.135 * rng.choice([1, 2, 3], 3000, p=[0.85, 0.12, 0.03])
    steps += rng.normal(0.0, 0.002, steps.size)
    steps[1500] = 4.0
    t = np.concatenate([[0.0], np.cumsum(steps)])
    assert line_gap_limit_s(t) == pytest.approx(2.5 * np.percentile(steps, 90))
    assert gap_spans(t).tolist() == [[t[1500], t[1501]]]


def test_an_outage_carrying_most_of_the_time_is_not_the_cycle() -> None:
    """A pair ranging 5 of 60 minutes: its 55 min outage carries most of its time but is
    one step, so it stays a gap (the time-weighted median leaves it out)."""
    t = np.concatenate([np.arange(0.0, 150.0), np.arange(3450.0, 3600.0)])
    assert line_gap_limit_s(t) == pytest.approx(2.5)
    assert gap_spans(t).tolist() == [[149.0, 3450.0]]
    bursty = leader_epochs()
    bursty = bursty[(bursty < 150.0) | (bursty > 3450.0)]
    assert gap_spans(bursty).shape == (1, 2)
    assert line_gap_limit_s(bursty) < 2.5


def test_break_gaps_puts_a_nan_in_each_gap() -> None:
    t = np.concatenate([np.arange(100.0), np.arange(130.0, 200.0), np.arange(203.0, 300.0)])
    x, y = break_gaps(t, t * 2.0)
    cut = np.flatnonzero(np.isnan(x))
    assert cut.tolist() == [100, 171]  # after 99 and after 199 (3 s > 2.5 s)
    assert np.isnan(y[cut]).all() and x[cut - 1].tolist() == [99.0, 199.0]
    assert x[cut + 1].tolist() == [130.0, 203.0]
    assert break_gaps(t, t, limit_s=40.0)[0].size == t.size


def test_gap_spans_with_run_bounds() -> None:
    t = np.concatenate([np.arange(10.0, 100.0), np.arange(130.0, 190.0)])
    spans = gap_spans(t, bounds=(0.0, 200.0))
    assert spans.tolist() == [[0.0, 10.0], [99.0, 130.0], [189.0, 200.0]]
    assert gap_spans(t).tolist() == [[99.0, 130.0]]
    assert gap_spans(np.array([]), bounds=(0.0, 5.0)).tolist() == [[0.0, 5.0]]
    assert gap_spans(np.array([])).shape == (0, 2)


def test_no_reference_spans_leave_out_the_outages() -> None:
    t = np.concatenate([np.arange(0.0, 100.0), np.arange(130.0, 300.0)])  # outage 99-130
    has = ~((t > 90.0) & (t < 160.0)) & ~((t > 200.0) & (t < 220.0))
    gaps = series_gaps(t, has)
    assert gaps.outages.tolist() == [[99.0, 130.0]]
    # float 91..159 around the outage: what is left on either side, and 201..219
    assert gaps.no_reference.tolist() == [[90.0, 99.0], [130.0, 160.0], [200.0, 220.0]]
    late = series_gaps(t, t > 250.0)
    assert late.no_reference.tolist() == [[0.0, 99.0], [130.0, 251.0]]
    none = series_gaps(t, np.zeros(t.size, dtype=bool))
    assert none.no_reference.tolist() == [[0.0, 99.0], [130.0, 299.0]]


def test_spans_are_shaded_under_the_data_once_in_the_legend() -> None:
    ax = Figure().subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    spans = np.array([[1.0, 2.0], [5.0, 6.0]])
    shade_gaps(ax, GapSpans(spans, spans + 10.0).shifted(1.0))
    assert shaded_spans(ax, "uwb_outage").tolist() == [[0.0, 1.0], [4.0, 5.0]]
    assert shaded_spans(ax, "no_reference").tolist() == [[10.0, 11.0], [14.0, 15.0]]
    _, labels = ax.get_legend_handles_labels()
    assert labels.count("UWB outage") == 1 and labels.count("No reference") == 1
    shades = [c for c in ax.collections if c.get_gid() in ("uwb_outage", "no_reference")]
    assert len(shades) == 2  # one artist per kind, however many spans
    assert all(c.get_zorder() < ax.get_lines()[0].get_zorder() for c in shades)
    assert ax.get_xlim()[1] >= 15.0  # the spans count in the x limits, as axvspan's


def test_decimated_position_line_keeps_the_gap_and_the_bursts_joined() -> None:
    """A long series drawn from its envelope: the 30 s outage stays a break, and the
    bursty epochs (two pairs) are one line, not thousands of pieces."""
    t = bursts(15_000)
    t = t[(t < 5000.0) | (t > 5030.0)]
    assert t.size > MAX_LINE_POINTS
    rows = pd.DataFrame(
        {
            "time": t,
            "platform": "A",
            "method": "di",
            "error_h": 0.1 + 0.05 * np.sin(t / 50.0),
        }
    )
    gaps = series_gaps(t, np.ones(t.size, dtype=bool))
    ax = Figure().subplots()
    plot_position_errors(ax, rows, methods=["di"], gaps=gaps)
    (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == "di"]
    x = np.asarray(line.get_xdata(), dtype=np.float64)
    assert x.size <= MAX_LINE_POINTS + 10  # decimated
    cut = np.flatnonzero(np.isnan(x))
    assert cut.size == 1
    assert x[cut - 1][0] < 5000.0 and x[cut + 1][0] > 5030.0
    shaded = shaded_spans(ax, "uwb_outage")
    assert len(shaded) == 1 and shaded[0, 0] < 5000.0


def test_convergence_line_breaks_where_the_steps_are_far_apart_in_time() -> None:
    rows = pd.DataFrame(
        {
            "pair": "A-B",
            "method": "di",
            "event": 1,
            "step": [1, 2, 3, 4, 5],
            "time": [100.0, 101.0, 102.0, 140.0, 141.0],
            "estimate": [0.6, 0.5, 0.45, 0.44, 0.44],
        }
    )
    ax = Figure().subplots()
    plot_nlos_convergence(ax, rows, gap_limit_s=2.5)
    y = np.asarray(ax.get_lines()[0].get_ydata(), dtype=np.float64)
    assert np.flatnonzero(np.isnan(y)).tolist() == [3]
    ax = Figure().subplots()
    plot_nlos_convergence(ax, rows)
    assert not np.isnan(np.asarray(ax.get_lines()[0].get_ydata(), dtype=np.float64)).any()


def test_a_short_series_with_outages_over_most_of_its_time_keeps_them() -> None:
    """90 samples a second apart around two 61 s holes (the holes last most of the
    series' time; under the old lenient 99th percentile they were taken for the cycle):
    both are gaps, the cycle is the 1 s step."""
    t = np.concatenate([np.arange(0.0, 30.0), np.arange(90.0, 120.0), np.arange(180.0, 210.0)])
    assert typical_step_s(t) == pytest.approx(1.0)
    assert gap_spans(t).tolist() == [[29.0, 90.0], [119.0, 180.0]]


def test_method_gaps_are_the_platform_gaps_of_the_methods_rows_together() -> None:
    """method_gaps takes each platform's rows per method, one platform at a time (issue
    11); its spans are platform_gaps' of the methods' rows concatenated, with the run's
    bounds over every platform."""
    rng = np.random.default_rng(3)

    def rows(t: np.ndarray, no_ref: slice) -> pd.DataFrame:
        err = rng.uniform(0.1, 1.0, t.shape[0])
        err[no_ref] = np.nan
        return pd.DataFrame({"time": t, "error_h": err})

    t_a = np.concatenate([bursts(300), bursts(200) + 400.0])  # an outage 300-400 s
    t_b = bursts(700) + 50.0  # starts later, ends after A: the bounds are the run's
    given = {
        "A": {"observed": rows(t_a, slice(100, 160)), "di": rows(t_a, slice(0, 0))},
        "B": {"observed": rows(t_b, slice(900, 1000))},
    }
    together = {p: pd.concat(list(m.values()), ignore_index=True) for p, m in given.items()}
    got, expected = method_gaps(given), platform_gaps(together)
    assert set(got) == set(expected) == {"A", "B"}
    for platform in got:
        assert np.array_equal(got[platform].outages, expected[platform].outages)
        assert np.array_equal(got[platform].no_reference, expected[platform].no_reference)
    assert got["A"].outages.shape[0] >= 2  # the outage and A's end before B's
    assert got["B"].no_reference.shape[0] == 1
