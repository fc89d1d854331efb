"""The methods' display names: one definition in the report (table_specs.METHOD_LABELS,
which the figures' line styles take), equal to what the range processors declare in the
registry (RangeStage.labels), since the report may not import the stages."""

from __future__ import annotations

from coopproc.report.style import METHOD_STYLES, method_style
from coopproc.report.table_specs import METHOD_LABELS, method_label, run_labels
from coopproc.stages.registry import RANGE_STAGES, declared_labels
from coopproc.stages.registry import method_label as registry_label


def test_the_report_names_the_methods_as_the_registry_does() -> None:
    declared = {m: names for stage in RANGE_STAGES.values() for m, names in stage.labels.items()}
    assert {"rn", "di"} <= set(declared)
    for method, (_, long) in declared.items():
        assert method_label(method) == long == registry_label(method, long=True)


def test_the_figures_take_the_tables_names() -> None:
    for method, label in METHOD_LABELS.items():
        assert METHOD_STYLES[method].label == label
    assert method_label("median") == "median"  # a method nobody labels keeps its name


def test_the_report_names_the_methods_as_the_run_declares() -> None:
    """run.json "method_labels" (written from the registry) name the methods in the
    report's tables and figures; outside a run, and for a run without them, the defaults."""
    assert declared_labels(("observed", "rn", "di", "median", "lsq")) == {
        "rn": "RN-Based",
        "di": "DI-Based",
    }
    with run_labels({"method_labels": {"median": "Median filter", "di": "DI (ours)"}}):
        assert method_label("median") == "Median filter"
        assert method_style("median").label == "Median filter"
        assert method_style("di").label == "DI (ours)"
        assert method_style("di").color == METHOD_STYLES["di"].color
        assert method_label("rn") == "RN-Based"  # not declared by the run: the default
    with run_labels({}):  # a run from before the labels
        assert method_label("di") == "DI-Based"
    assert method_label("median") == "median" and method_style("di").label == "DI-Based"
