"""Table 2 / Table 3 with confidence intervals and significance marks in every format, and
the table defects of issue 32: ties starred alike, ``--pairs B-A``, notes only for the
marks a table shows."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from report_synth import make_run

from coopproc.report.comparisons import comparisons
from coopproc.report.formats import SIGNIFICANT_MARK, format_tables, render_table
from coopproc.report.intervals import distance_intervals
from coopproc.report.latex_layout import SINGLE_PT
from coopproc.report.metrics import distance_metrics, position_metrics
from coopproc.report.run_tables import RunTables
from coopproc.report.tables import build_tables

BARE = make_run()  # 120 epochs of three pairs, an NLOS event on A-B and B-C
#: as `coopproc run` writes it: the 95 % intervals in the metrics tables, comparisons.csv
RUN = dataclasses.replace(
    BARE,
    metrics=distance_metrics(BARE.ranges, level=0.95),
    position_metrics=position_metrics(BARE.positions, level=0.95),
    comparisons=comparisons(
        BARE.ranges, BARE.positions, ("observed", "rn", "di"), ("nav", "observed", "rn", "di"), 0.95
    ),
)


def _tables(run: RunTables = RUN, **kwargs: object) -> dict[str, object]:
    return {t.key: t for t in build_tables(run, **kwargs)}  # type: ignore[arg-type]


def _row(table, group: str, method: str):  # type: ignore[no-untyped-def]
    return next(r for r in table.rows if r.group == group and r.method == method)


def test_terminal_shows_the_interval_after_the_value() -> None:
    ranges = RUN.ranges[RUN.ranges["pair"] == "A-B"]
    expected = distance_intervals(
        ranges["observed"].to_numpy(), ranges["reference"].to_numpy(), 0.95, ("A-B", "observed")
    )
    text = format_tables(RUN, "terminal")
    lo, hi = expected["rmse_lo"], expected["rmse_hi"]
    rmse = float(RUN.metrics.query("pair == 'A-B' and method == 'observed'")["rmse"].iloc[0])
    assert lo < rmse < hi
    assert f"{rmse:.4f} [{lo:.4f}, {hi:.4f}]" in text
    assert "in brackets the 95 % confidence interval" in text
    # max has no interval (the bootstrap of an extreme is inconsistent)
    table2 = _tables()["table2"]
    assert "max" not in _row(table2, "A-B", "observed").interval  # type: ignore[attr-defined]
    md = format_tables(RUN, "md")
    assert f"[{lo:.4f}, {hi:.4f}]" in md
    # --ci none: no brackets and no note about them
    bare = format_tables(RUN, "terminal", level=None)
    assert "[" not in bare.split("NLOS detection")[0] and "in brackets" not in bare


def test_other_levels_are_recomputed() -> None:
    wide = _row(_tables(level=0.99)["table2"], "A-B", "di").interval["rmse"]  # type: ignore[attr-defined]
    mid = _row(_tables()["table2"], "A-B", "di").interval["rmse"]  # type: ignore[attr-defined]
    narrow = _row(_tables(level=0.8)["table2"], "A-B", "di").interval["rmse"]  # type: ignore[attr-defined]
    assert wide[0] < mid[0] < narrow[0] < narrow[1] < mid[1] < wide[1]
    # a run directory without the interval columns and comparisons.csv: recomputed, the same
    assert _row(_tables(BARE)["table2"], "A-B", "di").interval["rmse"] == mid  # type: ignore[attr-defined]
    assert "in brackets the 80 % confidence" in format_tables(RUN, "terminal", level=0.8)


def test_significant_changes_are_marked_and_explained() -> None:
    # DI-Based's ranges carry 0.3 of the observed noise and none of its NLOS: its RMSE
    # change against Observed is significant on every pair
    table2 = _tables()["table2"]
    for pair in ("A-B", "A-C", "B-C"):
        assert "rmse" in _row(table2, pair, "di").significant  # type: ignore[attr-defined]
    text = format_tables(RUN, "terminal")
    assert re.search(rf"\(-\d+\.\d%{SIGNIFICANT_MARK}\)", text)
    assert f"{SIGNIFICANT_MARK} the change is significant" in text
    assert "p < 0.05" in text
    # a level nothing passes: no mark and no note about marks
    none = format_tables(RUN, "terminal", significance=1e-300)
    assert SIGNIFICANT_MARK not in none
    # --no-change: neither changes nor marks nor their notes
    plain = format_tables(RUN, "terminal", change=False)
    assert SIGNIFICANT_MARK not in plain and "in parentheses" not in plain
    csv = format_tables(RUN, "csv")
    header = csv.splitlines()[1].split(",")
    assert header[-1] == "significant" and "rmse_lo" in header and "max_lo" not in header


def test_ties_on_the_printed_value_are_all_starred() -> None:
    # issue 32: "0.0247" three times in Table 3, one starred
    pm = RUN.position_metrics.copy()
    at = pm["platform"] == "A"
    for method, value in (("nav", 0.031), ("observed", 0.02471), ("rn", 0.02468), ("di", 0.02474)):
        pm.loc[at & (pm["method"] == method), "mean"] = value
    run = dataclasses.replace(RUN, position_metrics=pm)
    table3 = _tables(run, level=None, significance=None)["table3"]
    starred = [r.method for r in table3.rows if r.group == "A" and "mean" in r.best]  # type: ignore[attr-defined]
    assert starred == ["observed", "rn", "di"]
    text = format_tables(run, "terminal", level=None, significance=None)
    block = text.split("Table 3.")[1].split("\nB ")[0]
    assert len(re.findall(r"0\.0247 \([^)]*\)\*", block)) == 2  # and Observed's "0.0247*"
    assert re.search(r"0\.0247\*", block)


def test_pairs_are_accepted_either_way_round() -> None:
    # issue 32: `report --table --pairs B-A` was refused while `--plots --pairs B-A` worked
    forward = format_tables(RUN, "terminal", pairs=["A-B"])
    assert format_tables(RUN, "terminal", pairs=["B-A"]) == forward
    assert "A-C" not in forward.split("Table 3.")[0]


def test_notes_only_for_the_marks_shown() -> None:
    # issue 32: footnotes about stars and changes under tables that have none
    table2 = _tables(level=None, significance=None)["table2"]
    no_best = dataclasses.replace(
        table2,
        rows=tuple(dataclasses.replace(r, best=frozenset()) for r in table2.rows),  # type: ignore[attr-defined]
    )
    text = render_table(no_best, "terminal", change=False)  # type: ignore[arg-type]
    assert "best of the column" not in text and "in parentheses" not in text
    assert text.rstrip().endswith("-")  # the rule closes the table: no note line
    md = render_table(no_best, "md", change=True)  # type: ignore[arg-type]
    assert "Bold:" not in md and "in parentheses the change" in md
    latex = render_table(no_best, "latex", change=False)  # type: ignore[arg-type]
    assert "in bold" not in latex and "change against Observed" not in latex


def test_latex_intervals_fit_the_page() -> None:
    tex = format_tables(RUN, "latex")
    # lo--hi (en dash) under the value, in the small type of the change rows
    assert re.search(r"\{\\(scriptsize|footnotesize) (\$-\$)?\d\.\d{4}--", tex)
    assert r"$^\dagger$" in tex
    widths = [float(w) for w in re.findall(r"about (\d+) pt wide", tex)]
    assert widths and max(widths) <= SINGLE_PT
    assert "confidence interval (block bootstrap over time)" in tex


def test_csv_intervals_are_the_metrics_columns() -> None:
    csv = format_tables(RUN, "csv").split("\n\n")[0].splitlines()
    header = csv[1].split(",")
    row = dict(
        zip(header, next(r for r in csv[2:] if r.startswith("A-B,di,")).split(","), strict=True)
    )
    expected = _row(_tables()["table2"], "A-B", "di").interval["rmse"]  # type: ignore[attr-defined]
    assert float(row["rmse_lo"]) == pytest.approx(expected[0], abs=1e-6)
    assert float(row["rmse_hi"]) == pytest.approx(expected[1], abs=1e-6)
    assert np.isfinite(float(row["smoothness_lo"]))
