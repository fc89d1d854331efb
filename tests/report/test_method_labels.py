"""The methods' display names: one definition in the report (table_specs.METHOD_LABELS,
which the figures' line styles take), equal to what the range processors declare in the
registry (RangeStage.labels), since the report may not import the stages."""

from __future__ import annotations

from coopproc.report.style import METHOD_STYLES
from coopproc.report.table_specs import METHOD_LABELS, method_label
from coopproc.stages.registry import RANGE_STAGES
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
