"""Reports of runs whose method chain differs from observed/rn/di: methods come from the run.

Chains (report_synth.CHAINS): without rn, without di, fusion only (observed, no NLOS
method, empty di.csv and nlos_events.csv) and with an extra range method ``median`` and
position methods ``median`` and ``lsq``; each with and without run.json ``"methods"``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from report_synth import CHAINS, PAIRS, chain_run

from coopproc.cli import main
from coopproc.errors import InputError
from coopproc.io.outdir import write_csv
from coopproc.report.figures import make_figures, write_figures
from coopproc.report.formats import format_tables
from coopproc.report.html import render_html
from coopproc.report.methods import (
    nlos_methods,
    position_methods,
    primary_method,
    range_methods,
)
from coopproc.report.run_tables import RunTables
from coopproc.report.rundir import RUN_FILES, load_run, ranges_columns
from coopproc.report.style import EXTRA_COLORS, METHOD_STYLES, method_style
from coopproc.report.tables import build_tables

#: chain -> (range methods, position methods, NLOS methods, primary) a report must see.
EXPECTED = {
    "default": (("observed", "rn", "di"), ("observed", "rn", "di"), ("rn", "di"), "di"),
    "no_rn": (("observed", "di"), ("observed", "di"), ("di",), "di"),
    "no_di": (("observed", "rn"), ("observed", "rn"), ("rn",), "rn"),
    "fusion": (("observed",), ("observed",), (), None),
    "extra": (
        ("observed", "rn", "median", "di"),
        ("observed", "rn", "median", "di", "lsq"),
        ("rn", "di"),
        "di",
    ),
}
#: Without run.json "methods": derived, known names first, then column order / by name.
DERIVED_EXTRA = (("observed", "rn", "di", "median"), ("observed", "rn", "di", "lsq", "median"))


def write_like_run(run: RunTables, out: Path) -> Path:
    """Write the tables as coopproc run does: write_csv with the RUN_FILES columns."""
    out.mkdir(parents=True, exist_ok=True)
    for name, attr, columns, _required in RUN_FILES:
        write_csv(getattr(run, attr), out / name, columns)
    (out / "run.json").write_text(json.dumps(dict(run.info)))
    return out


@pytest.fixture(scope="module", params=sorted(CHAINS))
def chain(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def loaded(chain: str, tmp_path_factory: pytest.TempPathFactory) -> RunTables:
    return load_run(write_like_run(chain_run(chain), tmp_path_factory.mktemp(chain) / "out"))


def test_default_chain_is_the_fixed_contract() -> None:
    assert CHAINS["default"][0] == ("observed", "rn", "di")
    assert ranges_columns(CHAINS["default"][0]) == (
        "time",
        "pair",
        "observed",
        "rn",
        "di",
        "reference",
        "nlos_flag",
        "nlos_estimate",
    )


def test_method_lists_from_run_json(chain: str) -> None:
    run = chain_run(chain)
    ranges, positions, nlos, primary = EXPECTED[chain]
    assert range_methods(run) == ranges
    assert position_methods(run) == positions
    assert nlos_methods(run) == nlos
    assert primary_method(run) == primary


def test_method_lists_derived_without_run_json_key(chain: str) -> None:
    run = chain_run(chain, listed=False)
    assert "methods" not in run.info
    ranges, positions, nlos, primary = EXPECTED[chain]
    if chain == "extra":
        ranges, positions = DERIVED_EXTRA
    assert range_methods(run) == ranges
    assert position_methods(run) == positions
    assert nlos_methods(run) == nlos
    assert primary_method(run) == primary


def test_primary_falls_back_to_the_last_processed_method() -> None:
    run = chain_run("extra")
    info = {**run.info, "methods": {"ranges": ["observed", "rn", "median"], "positions": []}}
    no_di = RunTables(**{**vars(run), "info": info})
    assert primary_method(no_di) == "median"
    assert position_methods(no_di) == ()


def test_listed_methods_without_a_column_are_left_out() -> None:
    run = chain_run("no_rn")
    info = {**run.info, "methods": {"ranges": ["observed", "rn", "di"]}}
    assert range_methods(RunTables(**{**vars(run), "info": info})) == ("observed", "di")


def test_load_run_reads_the_chain(chain: str, loaded: RunTables) -> None:
    ranges, positions, nlos, _ = EXPECTED[chain]
    # written through RUN_FILES, ranges.csv keeps the contract column order
    assert tuple(loaded.ranges.columns) == ranges_columns(ranges)
    assert range_methods(loaded) == ranges
    assert position_methods(loaded) == positions
    assert nlos_methods(loaded) == nlos
    assert len(loaded.ranges) == 3 * 120
    for column in ("di_dr", "di_reference"):  # header-only di.csv still reads as numbers
        assert loaded.di[column].dtype == np.float64
    if chain == "fusion":
        assert len(loaded.di) == 0 and len(loaded.nlos_events) == 0
        assert len(loaded.nlos_estimates) == 0


def test_load_run_derives_methods_of_an_old_run(tmp_path: Path) -> None:
    loaded = load_run(write_like_run(chain_run("extra", listed=False), tmp_path / "out"))
    assert (range_methods(loaded), position_methods(loaded)) == DERIVED_EXTRA


@pytest.mark.parametrize(
    ("chain_name", "damage", "message"),
    [
        (
            "fusion",
            lambda out: _drop_column(out / "ranges.csv", "nlos_flag"),
            r"ranges.csv:1: missing columns \['nlos_flag'\]; expected \['time', 'pair', "
            r"'observed', 'reference', 'nlos_flag', 'nlos_estimate'\]$",
        ),
        (
            "no_rn",
            lambda out: _set_info(out, {"ranges": ["observed", "rn", "di"]}),
            r"ranges.csv:1: missing columns \['rn'\]",
        ),
        (
            "extra",
            lambda out: _set_info(out, {"ranges": "observed,median"}),
            r'run.json: key "methods": expected an object of method-name lists',
        ),
        (
            "extra",
            lambda out: _replace(out / "ranges.csv", ",0.", ",x", count=1),
            r"ranges.csv:2: column '\w+': expected a number, found 'x",
        ),
    ],
)
def test_load_run_errors_are_one_line(
    tmp_path: Path, chain_name: str, damage, message: str
) -> None:  # type: ignore[no-untyped-def]
    out = write_like_run(chain_run(chain_name), tmp_path / "out")
    damage(out)
    with pytest.raises(InputError, match=message) as err:
        load_run(out)
    assert "\n" not in str(err.value)


def _drop_column(path: Path, column: str) -> None:
    lines = path.read_text().splitlines()
    index = lines[0].split(",").index(column)
    rows = [",".join(c for i, c in enumerate(line.split(",")) if i != index) for line in lines]
    path.write_text("\n".join(rows) + "\n")


def _set_info(out: Path, methods: object) -> None:
    info = json.loads((out / "run.json").read_text())
    (out / "run.json").write_text(json.dumps({**info, "methods": methods}))


def _replace(path: Path, old: str, new: str, count: int) -> None:
    path.write_text(path.read_text().replace(old, new, count))


def test_metrics_have_exactly_the_chains_methods(chain: str, loaded: RunTables) -> None:
    ranges, positions, nlos, _ = EXPECTED[chain]
    derived_order = DERIVED_EXTRA if chain == "extra" else (ranges, positions)
    for pair in PAIRS:
        rows = loaded.metrics[loaded.metrics["pair"] == pair]
        assert tuple(rows["method"]) == derived_order[0]  # metrics.csv as written
        assert (rows["n"] == 120).all()
    for platform in ("A", "C"):
        rows = loaded.position_metrics[loaded.position_metrics["platform"] == platform]
        assert tuple(rows["method"]) == ("nav", *derived_order[1])
    scores = loaded.nlos_scores
    assert scores is not None
    assert tuple(dict.fromkeys(scores["method"])) == nlos


def test_tables_show_the_run_methods_in_run_order(chain: str, loaded: RunTables) -> None:
    ranges, positions, nlos, _ = EXPECTED[chain]
    tables = {t.key: t for t in build_tables(loaded)}
    table2 = [r.method for r in tables["table2"].rows if r.group == "A-B"]
    assert tuple(table2) == ranges  # run.json order, whatever metrics.csv's order
    table3 = [r.method for r in tables["table3"].rows if r.group == "A"]
    assert tuple(table3) == ("nav", *positions)
    if nlos:
        assert tuple(r.method for r in tables["nlos"].rows if r.group == "A-B") == nlos
    else:
        assert "nlos" not in tables  # fusion only: nothing detects NLOS


def _method_cells(text: str, group: str) -> list[str]:
    """Method column of the markdown rows of one group (a row with an empty group cell
    belongs to the group above)."""
    cells, current = [], None
    for line in text.splitlines():
        if not line.startswith("| ") or line.startswith("| Pair") or "---" in line:
            continue
        parts = [p.strip() for p in line.strip("|").split("|")]
        if parts[0] == "Platform":
            break
        current = parts[0] or current
        if current == group:
            cells.append(parts[1])
    return cells


def test_markdown_and_terminal_label_unknown_methods_by_name(tmp_path: Path) -> None:
    run = load_run(write_like_run(chain_run("extra"), tmp_path / "out"))
    md = format_tables(run, "md")
    assert _method_cells(md, "A-B") == ["Observed", "RN-Based", "median", "DI-Based"]
    terminal = format_tables(run, "terminal")
    table3 = terminal.split("Table 3.")[1].split("NLOS detection")[0].splitlines()
    first = next(i for i, line in enumerate(table3) if line.startswith("A "))
    block = table3[first : first + 6]  # platform A: nav + five position methods
    labels = ["Own nav", "Observed", "RN-Based", "median", "DI-Based", "lsq"]
    assert [line[10:19].strip() for line in block] == labels
    assert table3[first + 6].startswith("B ")


def test_markdown_without_rn_has_no_rn_rows(tmp_path: Path) -> None:
    run = load_run(write_like_run(chain_run("no_rn"), tmp_path / "out"))
    md = format_tables(run, "md")
    assert "RN-Based" not in md
    assert _method_cells(md, "B-C") == ["Observed", "DI-Based"]


def test_style_of_an_unknown_method_is_deterministic_and_named() -> None:
    for name in ("median", "lsq"):
        style = method_style(name)
        assert style.label == name and style == method_style(name)
        assert style.color not in {s.color for s in METHOD_STYLES.values()}
    assert method_style("median") != method_style("lsq")
    fixed = {s.color for s in METHOD_STYLES.values()}
    assert not fixed & set(EXTRA_COLORS)  # an added method never takes a fixed colour
    assert len(fixed) == len(METHOD_STYLES)  # one colour each


#: chain -> figures its data allow (no DI table -> no di_errors; no NLOS -> no convergence).
FIGURES = {
    "default": {"distance_errors", "di_errors", "position_errors", "nlos_convergence"},
    "no_rn": {"distance_errors", "di_errors", "position_errors", "nlos_convergence"},
    "no_di": {"distance_errors", "position_errors", "nlos_convergence"},
    "fusion": {"distance_errors", "position_errors"},
    "extra": {"distance_errors", "di_errors", "position_errors", "nlos_convergence"},
}
#: Figures of every run with positions and a reference, whatever its chain.
ALWAYS = {"trajectories", "error_cdf", "error_track"}


def test_figures_draw_the_run_methods(chain: str, loaded: RunTables) -> None:
    ranges, positions, _, primary = EXPECTED[chain]
    figures = make_figures(loaded)
    assert set(figures) == FIGURES[chain] | ALWAYS
    for ax in figures["distance_errors"].axes:
        gids = [ln.get_gid() for ln in ax.get_lines() if ln.get_gid() != "nlos_span"]
        assert tuple(g for g in gids if g in ranges) == ranges
        assert set(gids) - set(ranges) <= {None}
        spans = [p for p in ax.patches if p.get_gid() == "nlos_span"]
        pair = ax.get_title(loc="left").split()[-1]
        events = loaded.nlos_events
        assert len(spans) == int(((events["pair"] == pair) & (events["method"] == primary)).sum())
    ax = figures["position_errors"].axes[0]
    assert [ln.get_gid() for ln in ax.get_lines()] == list(positions)
    legend = [t.get_text() for t in figures["position_errors"].legends[0].get_texts()]
    assert [method_style(m).label for m in positions] == legend
    track = figures["trajectories"].axes[0]
    track_gids = [str(ln.get_gid()) for ln in track.get_lines()]
    tracks = [g for g in track_gids if g not in ("start", "end")]  # the shared markers
    assert tracks == ["reference", "nav", *positions]
    if "nlos_convergence" in figures:
        for ax in figures["nlos_convergence"].axes:
            assert primary in {ln.get_gid() for ln in ax.get_lines()}


def test_without_di_the_last_processed_method_is_primary() -> None:
    """rn and a later method ``smooth`` both detect NLOS: smooth's events are shaded and
    get the convergence panels (one event on A-B), rn's join them where they overlap and
    get panels of their own where they do not (B-C)."""
    run = chain_run("no_di")
    ranges = run.ranges.copy()
    ranges.insert(4, "smooth", ranges["rn"] + 0.01)
    rn_events = run.nlos_events[run.nlos_events["method"] == "rn"]
    smooth = rn_events[rn_events["pair"] == "A-B"].assign(method="smooth")
    rn_est = run.nlos_estimates[run.nlos_estimates["method"] == "rn"]
    smooth_est = rn_est[rn_est["pair"] == "A-B"].assign(method="smooth")
    info = {**run.info, "methods": {"ranges": ["observed", "rn", "smooth"], "positions": []}}
    run = RunTables(
        **{
            **vars(run),
            "ranges": ranges,
            "nlos_events": pd.concat([run.nlos_events, smooth], ignore_index=True),
            "nlos_estimates": pd.concat([run.nlos_estimates, smooth_est], ignore_index=True),
            "info": info,
        }
    )
    assert primary_method(run) == "smooth" and nlos_methods(run) == ("rn", "smooth")
    figures = make_figures(run)
    spans = {
        ax.get_title(loc="left").split()[-1]: sum(p.get_gid() == "nlos_span" for p in ax.patches)
        for ax in figures["distance_errors"].axes
    }
    assert spans == {"A-B": 1, "A-C": 0, "B-C": 0}
    panels = figures["nlos_convergence"].axes
    assert [ax.get_title(loc="left") for ax in panels] == [
        "(a) A-B, event 1 (t = 31 s)",
        "(b) B-C, RN-Based event 1 (t = 51 s)",
    ]
    assert {ln.get_gid() for ln in panels[0].get_lines()} >= {"smooth", "rn"}
    assert {ln.get_gid() for ln in panels[1].get_lines()} - {"reference_bias"} == {"rn"}
    assert "position_errors" not in figures  # the run lists no position method


@pytest.mark.slow
def test_write_figures_and_html(chain: str, loaded: RunTables, tmp_path: Path) -> None:
    written = write_figures(loaded, tmp_path / "figures", dpi=30)
    assert {p.stem for p in written} == FIGURES[chain] | ALWAYS
    page = render_html(tmp_path, loaded)
    assert page.count("data:image/png;base64,") == len(written)
    assert "<caption>Table 2. Distance errors per pair and method</caption>" in page
    assert ("<caption>NLOS detection against the reference</caption>" in page) == (
        chain != "fusion"
    )
    if chain == "extra":
        assert "<td>median</td>" in page and "<td>lsq</td>" in page


@pytest.mark.slow
def test_cli_report_on_a_fusion_only_run(tmp_path: Path) -> None:
    out = write_like_run(chain_run("fusion"), tmp_path / "out")
    table = CliRunner().invoke(main, ["report", str(out), "--table"])
    assert table.exit_code == 0, table.output
    assert "Observed" in table.output and "DI-Based" not in table.output
    assert "NLOS detection" not in table.output
    plots = CliRunner().invoke(main, ["report", str(out), "--plots", "--dpi", "50", "--html"])
    assert plots.exit_code == 0, plots.output
    assert sorted(p.name for p in (out / "figures").iterdir()) == [
        "distance_errors.png",
        "error_cdf.png",
        "error_track.png",
        "position_errors.png",
        "trajectories.png",
    ]
    assert (out / "report.html").is_file()


def test_a_one_step_event_gets_whole_step_ticks() -> None:
    """An RN-only run's events have one estimation step: the axis spans steps 0 to 2."""
    from matplotlib.figure import Figure

    from coopproc.report.plots import plot_nlos_convergence

    rows = chain_run("no_di").nlos_estimates.iloc[:1]
    ax = plot_nlos_convergence(Figure().subplots(), rows)
    assert ax.get_xlim() == (0.0, 2.0)
    assert all(float(t).is_integer() for t in ax.get_xticks())
