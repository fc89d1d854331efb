"""The paper's tables in every format: golden files, the change against Observed (% as the
paper quotes it for magnitudes, absolute for the signed mean and dB), filters.

Regenerate the golden files after an intended change with
``COOPPROC_UPDATE_GOLDEN=1 pytest tests/report/test_report_tables.py``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from report_synth import paper_run

from coopproc.errors import ConfigError
from coopproc.report.change import Change
from coopproc.report.formats import format_tables
from coopproc.report.tables import build_tables

GOLDEN = Path(__file__).parent / "golden"
SUFFIX = {"terminal": "txt", "csv": "csv", "md": "md", "latex": "tex"}


@pytest.mark.parametrize("fmt", list(SUFFIX))
def test_golden(fmt: str) -> None:
    text = format_tables(paper_run(), fmt)  # type: ignore[arg-type]
    path = GOLDEN / f"paper_tables.{SUFFIX[fmt]}"
    if os.environ.get("COOPPROC_UPDATE_GOLDEN"):
        path.write_text(text)
    assert text == path.read_text()


def _row(table_key: str, group: str, method: str):  # type: ignore[no-untyped-def]
    tables = {t.key: t for t in build_tables(paper_run())}
    return next(r for r in tables[table_key].rows if r.group == group and r.method == method)


def _pct(change: Change | None) -> float:
    assert change is not None and change.unit == "%"
    return change.value


def test_relative_change_matches_the_papers_text() -> None:
    # paper 000 section 4.4: A-C RN-Based max +2.45 %; DI-Based max -40.27 %,
    # RMSE -37.44 %, smoothness -20.32 % ("improved by 20.32 %").
    rn = _row("table2", "A-C", "rn")
    assert _pct(rn.change["max"]) == pytest.approx(2.45, abs=0.01)
    di = _row("table2", "A-C", "di")
    expected = {"max": -40.27, "rmse": -37.44, "smoothness": -20.32}
    for name, value in expected.items():
        assert _pct(di.change[name]) == pytest.approx(value, abs=0.01), name
    # the paper's "mean -17.07 %" (of magnitudes) and "SNR +7.41 %" are absolute changes
    # here: the signed mean in m (0.0034 - 0.0041), the SNR in dB (55.5046 - 51.6731)
    assert di.change["mean"] == Change(pytest.approx(-0.0007), "m", 4)  # type: ignore[arg-type]
    assert di.change["snr_db"] == Change(pytest.approx(3.8315), "dB", 2)  # type: ignore[arg-type]
    # Table 3 text: mean error of A and C reduced by 27.05 / 29.39 % (RN), 35.76 / 40.62 % (DI)
    for platform, method, value in (
        ("A", "rn", -27.05),
        ("C", "rn", -29.39),
        ("A", "di", -35.76),
        ("C", "di", -40.62),
    ):
        assert _pct(_row("table3", platform, method).change["mean"]) == pytest.approx(
            value, abs=0.01
        )


def test_best_marks() -> None:
    # mean: smallest magnitude; smoothness: closest to 1; snr: largest
    assert "mean" in _row("table2", "A-B", "di").best
    assert "smoothness" in _row("table2", "A-B", "di").best
    assert _row("table2", "A-C", "observed").best == frozenset()
    assert "f1" in _row("nlos", "B-C", "di").best


def test_filters_and_metric_choice() -> None:
    text = format_tables(paper_run(), "csv", metrics=["rmse", "f1"], pairs=["B-C"], platforms=["C"])
    blocks = text.split("\n\n")
    assert blocks[0].splitlines()[1:] == [
        "pair,method,rmse,rmse_change,rmse_change_unit,best",
        "B-C,observed,0.143800,,,",
        "B-C,rn,0.060800,-57.72,%,",
        "B-C,di,0.040400,-71.91,%,rmse",
    ]
    assert "C,di,0.144000,-40.62,%,rmse" in blocks[1]  # rmse = 1.2 x mean
    assert "A-B" not in text and "\nA," not in text
    assert blocks[2].splitlines()[1] == "pair,method,f1,best"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"metrics": ["rmes"]}, "unknown metric 'rmes'; did you mean 'rmse'?"),
        ({"pairs": ["A-D"]}, "unknown pair 'A-D'; the run has A-B, A-C, B-C"),
        ({"platforms": ["B"]}, "unknown platform 'B'; the run has A, C"),
    ],
)
def test_bad_names(kwargs: dict[str, list[str]], message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("?", r"\?")):
        format_tables(paper_run(), "terminal", **kwargs)  # type: ignore[arg-type]
