"""Figure gallery: every figure kind rendered through the real code on sample_logs and on a
session with UWB outages and a float-reference window, made with the project's tools
(``coopproc inject`` and a copy of sample_logs whose ref_C.pos turns float for 40 s).

Checked on the files: every figure kind is a non-blank PNG. Checked on the figure objects
(``make_figures``): no line joins two samples across missing data (a segment longer than
any step of the 1 Hz data), in particular across the outage and float windows, and the
``UWB outage`` / ``No reference`` spans cover those windows in the panels they concern.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Iterator
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from coopproc.cli import main
from coopproc.report.consistency_figure import CONSISTENCY_FIGURE_NAMES
from coopproc.report.dr_states_figure import DR_FIGURE_NAMES
from coopproc.report.figures import FIGURE_NAMES, make_figures, write_figures
from coopproc.report.gaps import shaded_spans
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import load_run

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs"
T0 = 108000.0  # sample_logs' first epoch (GPS TOW)
#: Injected outages (seconds from T0) and the pairs they cut (None: every pair).
#: +388...+392 s falls inside an NLOS event of A-B (+381...+399 s).
OUTAGES = ((200.0, 240.0, ("A-B",)), (388.0, 392.0, ("A-B",)), (420.0, 445.0, None))
#: ref_C.pos rows turned float (Q=2), seconds from T0 (06:05:00 to 06:05:40 GPST).
FLOAT_C = (300.0, 340.8)
#: gids of the shaded spans (one collection per kind in a panel)
SHADES = ("uwb_outage", "no_reference")
PAIRS = ("A-B", "A-C", "B-C")
#: The sample's ranges come once a second and its references five times a second: a
#: drawn segment longer than this joins samples across missing data.
MAX_SEGMENT_S = 2.6
#: The same for a track in the plane: the platforms move at most ~3 m/s.
MAX_SEGMENT_M = 8.0


#: date, time, latitude, longitude, height, then Q = 1
_Q_FIXED = re.compile(r"^(\S+ \S+(?:\s+\S+){3}\s+)1(\s)")


def _cli(*args: str) -> None:
    result = CliRunner().invoke(main, list(args), catch_exceptions=False)
    assert result.exit_code == 0, result.output


def _float_window(pos: Path, start: str, end: str) -> int:
    """Turn the fixed (Q=1) rows of an RTKLIB .pos file with start <= hh:mm:ss <= end into
    float rows (Q=2), spacing kept; returns how many."""
    lines = pos.read_text().splitlines(keepends=True)
    n = 0
    for i, line in enumerate(lines):
        if not line.startswith("%") and start <= line[11:19] <= end:
            lines[i], k = _Q_FIXED.subn(r"\g<1>2\g<2>", line)
            n += k
    pos.write_text("".join(lines))
    return n


def _run(session: Path, out: Path) -> RunTables:
    _cli("run", str(session), "-o", str(out), "--no-figures", "-q")
    return load_run(out)


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> RunTables:
    return _run(SAMPLE, tmp_path_factory.mktemp("sample") / "out")


@pytest.fixture(scope="module")
def gap_run(tmp_path_factory: pytest.TempPathFactory) -> RunTables:
    root = tmp_path_factory.mktemp("gaps")
    session = root / "session"
    args = ["inject", str(SAMPLE), "-o", str(session)]
    for start, end, pairs in OUTAGES:
        args += ["--outage", f"+{start:g}", f"+{end:g}"]
        if pairs:
            args += ["--pairs", ",".join(pairs)]
    _cli(*args)
    assert _float_window(session / "ref_C.pos", "06:05:00", "06:05:40") == 205  # 5 Hz, 40.8 s
    return _run(session, root / "out")


@pytest.fixture(scope="module")
def gap_figures(gap_run: RunTables) -> dict[str, Figure]:
    return make_figures(gap_run)


def _lines(fig: Figure) -> Iterator[tuple[Axes, str, np.ndarray, np.ndarray]]:
    for ax in fig.axes:
        for line in ax.get_lines():
            x = np.asarray(line.get_xdata(), dtype=np.float64)
            y = np.asarray(line.get_ydata(), dtype=np.float64)
            drawn = line.get_linestyle() not in ("None", "none", "")
            if x.size > 1 and drawn and line.get_gid() is not None:  # not axhline
                yield ax, str(line.get_gid()), x, y


def _segments(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end index of every drawn segment (both ends finite)."""
    ok = np.isfinite(x) & np.isfinite(y)
    at = np.flatnonzero(ok[:-1] & ok[1:])
    return at, at + 1


def _panel(fig: Figure, key: str) -> Axes:
    found = [ax for ax in fig.axes if ax.get_title(loc="left").endswith(f" {key}")]
    assert len(found) == 1, key
    return found[0]


def _spans(ax: Axes, gid: str) -> list[tuple[float, float]]:
    return [(float(a), float(b)) for a, b in shaded_spans(ax, gid)]


def _covered(spans: list[tuple[float, float]], start: float, end: float) -> bool:
    return any(a <= start and b >= end for a, b in spans)


TIME_FIGURES = ("distance_errors", "di_errors", "position_errors")


def _check_no_bridges(figures: dict[str, Figure]) -> int:
    """No time-series segment longer than the data's step, no track chord; returns how
    many lines were checked."""
    checked = 0
    for stem, fig in figures.items():
        name = stem if stem in FIGURE_NAMES else stem.rsplit("_", 1)[0]
        for ax, gid, x, y in _lines(fig):
            lo, hi = _segments(x, y)
            if name in TIME_FIGURES:
                longest = float(np.max(x[hi] - x[lo], initial=0.0))
                assert longest <= MAX_SEGMENT_S, (stem, ax.get_title(), gid, longest)
                checked += 1
            elif name in ("trajectories", "error_track") and gid != "zoom":
                chord = float(np.max(np.hypot(x[hi] - x[lo], y[hi] - y[lo]), initial=0.0))
                assert chord <= MAX_SEGMENT_M, (stem, ax.get_title(), gid, chord)
                checked += 1
    return checked


@pytest.mark.slow  # every figure kind drawn twice, at 40 dpi
@pytest.mark.parametrize("which", ["sample", "gaps"])
def test_every_figure_kind_is_a_nonblank_png(
    which: str, sample_run: RunTables, gap_run: RunTables, tmp_path: Path
) -> None:
    run = sample_run if which == "sample" else gap_run
    paths = write_figures(run, tmp_path / "figures", dpi=40)
    # every run's figures, the fusion's DR states (a run with followers, state "dr") and
    # its consistency (a run with a cooperative fusion: range_weights.csv)
    expected = (*FIGURE_NAMES, *DR_FIGURE_NAMES, *CONSISTENCY_FIGURE_NAMES)
    assert sorted(p.stem for p in paths) == sorted(expected)
    for path in paths:
        assert path.stat().st_size > 3000, path.name
        pixels = mpimg.imread(path)[..., :3]
        # more than a frame: a fair share of the pixels are neither white nor one colour
        inked = np.mean(np.any(pixels < 0.9, axis=-1))
        assert 0.02 < inked < 0.6, (path.name, inked)
        assert np.unique(pixels.reshape(-1, 3), axis=0).shape[0] > 20, path.name
    if which == "gaps":  # keep the gallery for a look: --basetemp shows where
        shutil.copytree(tmp_path / "figures", tmp_path.parent / "gallery_gaps", dirs_exist_ok=True)


def test_sample_lines_do_not_bridge_the_reference_gaps(sample_run: RunTables) -> None:
    figures = make_figures(sample_run)
    assert set(figures) == {*FIGURE_NAMES, *DR_FIGURE_NAMES, *CONSISTENCY_FIGURE_NAMES}
    assert _check_no_bridges(figures) >= 3 * 3 * 3  # 3 figures x 3 panels x 3 lines
    # sample_logs' own float reference epochs (ref_A.pos: Q != 1 from +468 to +488 s) shaded
    ax = _panel(figures["position_errors"], "A")
    assert _covered(_spans(ax, "no_reference"), 468.0, 488.0)
    assert not _spans(ax, "uwb_outage")


def test_gap_lines_break_inside_every_window(gap_figures: dict[str, Figure]) -> None:
    assert _check_no_bridges(gap_figures) >= 3 * 3 * 3
    windows = [(a, b, pairs or PAIRS) for a, b, pairs in OUTAGES]
    windows.append((*FLOAT_C, ("A-C", "B-C")))
    for name in ("distance_errors", "di_errors"):
        for start, end, pairs in windows:
            for pair in pairs:
                for _, gid, x, y in _lines_of(_panel(gap_figures[name], pair)):
                    lo, hi = _segments(x, y)
                    inside = (x[hi] > start) & (x[lo] < end)
                    assert not inside.any(), (name, pair, gid, start, end)
                    # drawn up to the window on both sides: the line stops, not the data
                    assert np.nanmin(np.abs(x - start)) < 3.0 and np.nanmin(np.abs(x - end)) < 3.0


def _lines_of(ax: Axes) -> Iterator[tuple[Axes, str, np.ndarray, np.ndarray]]:
    for line in ax.get_lines():
        x = np.asarray(line.get_xdata(), dtype=np.float64)
        if x.size > 1 and line.get_gid() is not None:
            yield ax, str(line.get_gid()), x, np.asarray(line.get_ydata(), dtype=np.float64)


def test_gap_spans_cover_the_outage_and_float_windows(gap_figures: dict[str, Figure]) -> None:
    for name in ("distance_errors", "di_errors"):
        fig = gap_figures[name]
        for start, end, pairs in OUTAGES:
            for pair in PAIRS:
                spans = _spans(_panel(fig, pair), "uwb_outage")
                assert _covered(spans, start, end) == (pairs is None or pair in pairs), (
                    name,
                    pair,
                    start,
                )
        for pair in ("A-C", "B-C"):
            assert _covered(_spans(_panel(fig, pair), "no_reference"), *FLOAT_C), (name, pair)
        assert not _covered(_spans(_panel(fig, "A-B"), "no_reference"), *FLOAT_C)
    fig = gap_figures["position_errors"]
    for platform in ("A", "B", "C"):
        ax = _panel(fig, platform)
        assert _covered(_spans(ax, "uwb_outage"), 420.0, 445.0), platform
        # A and B still range with C during the A-B outage: their positions go on
        assert not _covered(_spans(ax, "uwb_outage"), 200.0, 240.0), platform
        assert _covered(_spans(ax, "no_reference"), *FLOAT_C) == (platform == "C"), platform
    # each kind is in the figure's legend once, under the data
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels.count("UWB outage") == 1 and labels.count("No reference") == 1
    line_z = min(ln.get_zorder() for ln in _panel(fig, "C").get_lines())
    shades = [c for c in _panel(fig, "C").collections if c.get_gid() in SHADES]
    assert len(shades) == 2 and all(c.get_zorder() < line_z for c in shades)
