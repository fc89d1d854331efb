"""The stage chain: [pipeline] resolved into ordered steps, and its config errors."""

from __future__ import annotations

import pytest

from coopproc.cli.config_cmd import render_config
from coopproc.errors import ConfigError
from coopproc.run.chain import PipelineParams, chain_lines, resolve
from coopproc.run.config import RunConfig, run_config_from_toml
from coopproc.stages.ranging.median import MedianParams
from coopproc.stages.shared.lsq import LsqParams


def _labels(**pipeline: object) -> list[str]:
    config = run_config_from_toml({"pipeline": pipeline})
    return [s.label for s in resolve(config.pipeline)]


def test_default_chain_is_paper_000s() -> None:
    steps = resolve(PipelineParams())
    assert [s.label for s in steps] == [
        "fusion (observed)",
        "ranging (rn, di)",
        "fusion (rn)",
        "fusion (di)",
    ]
    assert steps[0].outputs == ("positions:observed", "cp")
    assert steps[1].inputs == ("ranges:observed", "cp")
    assert steps[2].inputs == ("ranges:rn", "positions:observed")
    assert chain_lines(steps)[1] == (
        "2. ranging (rn, di)   ranges:observed, cp -> ranges:rn, ranges:di"
    )


def test_partial_chains() -> None:
    assert _labels(ranges=[]) == ["fusion (observed)"]
    assert _labels(ranges=["di"]) == ["fusion (observed)", "ranging (di)", "fusion (di)"]
    # the column order is the config's; one ranging step gives both methods; a step runs
    # as soon as its inputs exist (median needs no cooperative solution)
    assert _labels(ranges=["di", "median", "rn"]) == [
        "median (median)",
        "fusion (observed)",
        "ranging (di, rn)",
        "fusion (di)",
        "fusion (median)",
        "fusion (rn)",
    ]
    assert _labels(ranges=["median"], positions=["lsq"]) == [
        "median (median)",
        "lsq (observed)",
        "lsq (median)",
    ]


def test_cp_provider_added_when_no_estimator_gives_it() -> None:
    config = run_config_from_toml({"pipeline": {"ranges": ["di"], "positions": []}})
    steps = resolve(config.pipeline)
    assert [s.label for s in steps] == ["fusion (observed)", "ranging (di)"]
    assert steps[0].reason == "the cooperative solution that ranging needs"
    assert "cp" in steps[0].outputs
    steps = resolve(PipelineParams(ranges=("rn",), positions=("lsq",)))
    assert [s.methods for s in steps] == [("observed",), ("rn",), ("lsq",), ("lsq_rn",)]


@pytest.mark.parametrize(
    ("pipeline", "message"),
    [
        ({"ranges": ["dii"]}, "unknown range method 'dii' (did you mean 'di'?)"),
        ({"positions": ["fusoin"]}, "unknown position estimator 'fusoin' (did you mean 'fusion'?)"),
        ({"ranges": ["di", "di"]}, "ranges: 'di' is listed twice"),
        ({"ranges": "di"}, "expected a list"),
        ({"stages": ["di"]}, "unknown key 'stages'"),
    ],
)
def test_bad_pipeline_is_one_line(pipeline: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError) as err:
        run_config_from_toml({"pipeline": pipeline}, where="run.toml")
    text = str(err.value)
    assert message in text and text.startswith("run.toml [pipeline]") and "\n" not in text


def test_stage_sections() -> None:
    config = run_config_from_toml({"median": {"window": 9}})
    assert config.params_for("median") == MedianParams(window=9)
    assert isinstance(config.params_for("fusion.lsq"), LsqParams)
    assert config.params_for("ranging") is config.ranging
    with pytest.raises(ConfigError, match=r"\[median\]: window = 4, expected an odd number"):
        run_config_from_toml({"median": {"window": 4}})
    with pytest.raises(ConfigError, match=r"unknown key 'medain' \(did you mean 'median'\?\)"):
        run_config_from_toml({"medain": {}})


def test_config_prints_the_chain_and_reads_back() -> None:
    text = render_config(RunConfig())
    assert "# the chain this runs (step: inputs -> outputs):" in text
    assert "#   4. fusion (di)        ranges:di, positions:observed -> positions:di" in text
    assert 'ranges = ["rn", "di"]' in text and "[median]\n" in text
    import tomllib

    assert run_config_from_toml(tomllib.loads(text)) == RunConfig()
