"""The method names the runner and the summary take from the registry (issue 34 part 4):
each range processor's labels and its primary NLOS method, no fixed names in run/."""

from __future__ import annotations

from pathlib import Path

from coopproc.stages.registry import method_label, nlos_primary, nlos_source, primary_method


def test_the_primary_nlos_method_is_declared_not_named() -> None:
    assert nlos_primary() == ("di",)  # the ranging stage's declaration (DATA.md)
    assert nlos_source(["rn", "di"]) == "di"  # whatever the chain's order
    assert nlos_source(["rn"]) == "rn"  # no primary method: the first that detects NLOS
    assert nlos_source(["median", "rn"]) == "median"
    assert nlos_source([]) is None


def test_labels_come_from_the_range_processor() -> None:
    assert method_label("di") == "DI" and method_label("di", long=True) == "DI-Based"
    assert method_label("rn", long=True) == "RN-Based"
    assert method_label("median") == "median"  # declares none: its own name
    assert method_label("observed") == "observed"


def test_the_runner_and_summary_hold_no_method_names() -> None:
    """The modules that chose by name before read the registry now."""
    root = Path(__file__).resolve().parents[2] / "coopproc" / "run"
    for name in ("summary.py", "pipeline.py"):
        text = (root / name).read_text(encoding="utf-8")
        assert '"di"' not in text and '"rn"' not in text, name


def test_the_primary_method_is_the_declared_one_else_the_last() -> None:
    assert primary_method(["rn", "di"]) == "di"
    assert primary_method(["di", "median"]) == "di"
    assert primary_method(["rn", "median"]) == "median"
    assert primary_method([]) is None


def test_a_reporter_takes_the_primary_method_the_run_lists() -> None:
    """report/methods.py reads run.json ``methods.primary``; a run directory without it
    (written before) keeps the old rule, ``di`` if present."""
    import pandas as pd

    from coopproc.report.methods import primary_method as reported
    from coopproc.report.run_tables import RunTables

    empty = pd.DataFrame()
    ranges = pd.DataFrame(columns=["time", "pair", "observed", "di", "median", "reference"])

    def run(info: dict[str, object]) -> RunTables:
        return RunTables(ranges, empty, empty, empty, empty, empty, empty, info=info)

    listed = {"ranges": ["observed", "di", "median"], "positions": ["observed"]}
    assert reported(run({"methods": listed})) == "di"  # older run: the old rule
    assert reported(run({"methods": {**listed, "primary": ["median"]}})) == "median"
    assert reported(run({"methods": {**listed, "primary": []}})) is None
