"""The run configuration: one TOML file, one section per stage, every key optional.

``coopproc run SESSION --config run.toml`` reads it; ``coopproc config`` prints the
effective configuration with each key's help. Sections:

- ``[run]``: what the pipeline does around the stages (this module, :class:`RunParams`);
- ``[pipeline]``: which methods the chain produces (:mod:`coopproc.run.chain`);
- ``[ranging]`` with sub-tables ``di``, ``distance``, ``nlos``, ``rn``
  (:mod:`coopproc.stages.ranging.config`);
- ``[fusion]`` (:mod:`coopproc.stages.fusion.fuse`);
- one table per other registered stage (e.g. ``[median]``), named by its ``section``.

Defaults reproduce paper 000's experiment (gamma = 3 sigma, M = 3 s, ...). An unknown
section or key is an error naming the nearest valid one.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from coopproc.configtools import check_keys, from_table, to_table
from coopproc.errors import ConfigError
from coopproc.run.chain import PipelineParams
from coopproc.stages.fusion.fuse import FusionParams, fusion_params_from_toml
from coopproc.stages.ranging.config import RangingConfig, ranging_config_from_toml
from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES

__all__ = ["RunConfig", "RunParams", "load_run_config", "run_config_from_toml"]


@dataclass(frozen=True)
class RunParams:
    """``[run]``: how the pipeline chains the stages."""

    cp_solution: Literal["forward", "smoothed"] = field(
        default="forward",
        metadata={
            "help": "which cooperative solution (fusion with observed ranges) gives the "
            "CP distance increments: 'forward' = the causal filter, as in paper 000's "
            "real-time system; 'smoothed' = after the RTS smoother"
        },
    )
    positions_at: Literal["ranges", "nav"] = field(
        default="ranges",
        metadata={
            "help": "epochs of positions.csv: 'ranges' = the range epochs, 'nav' = the "
            "navigation rate (dead reckoning between range updates)"
        },
    )
    figures: bool = field(
        default=True,
        metadata={"help": "write figures/ (report.html is written either way, without them)"},
    )
    figure_style: Literal["default", "single-column", "double-column"] = field(
        default="default",
        metadata={
            "help": "figure sizes and fonts: 'single-column' (3.5 in wide, 8 pt), "
            "'double-column' (7.16 in, 9 pt) or 'default'; --style overrides it"
        },
    )
    max_pages: int = field(
        default=2,
        metadata={
            "help": "most pages (of --max-panels, 24, panels) a figure draws unless "
            "--pairs / --platforms chose its panels: beyond, the pairs with the largest "
            "observed range RMSE, the platforms with the largest position error, the "
            "largest NLOS events (the run notes say what was left out); 0 = all; "
            "--max-pages overrides it"
        },
    )
    parallel_fusion: bool | Literal["auto"] = field(
        default="auto",
        metadata={
            "help": "run the fusions of the processed range sets (and any other position "
            "steps that do not need each other) two at a time, one in a forked process: "
            "'auto' = with 200000 to 1 M range rows (the second fusion adds about 1 kB "
            "a range row to the peak memory), 2+ CPUs and twice that memory available; "
            "true = whenever the process can fork, at any size; false = one after the "
            "other (same results either way; docs/scale.md)"
        },
    )
    outages: tuple[tuple[float, float], ...] = field(
        default=(),
        metadata={
            "help": "UWB outage windows [[t0, t1], ...], seconds from the session start: "
            "the ranges inside are withheld from every method (paper 003 sec. 3.4), "
            "positions.csv is at the navigation rate, outages.csv scores each method's "
            "drift inside each window; --outage T0:T1 replaces them"
        },
    )
    format: Literal["csv", "parquet"] = field(
        default="csv",
        metadata={
            "help": "form of the per-epoch tables (ranges, di, nlos_estimates, positions): "
            "'csv', or 'parquet' (<name>.parquet, same numbers; needs pyarrow: "
            'pip install "coopproc[parquet]"); the summary tables are always CSV'
        },
    )

    def __post_init__(self) -> None:
        if self.max_pages < 0:
            raise ValueError(f"max_pages must be >= 0 (0: all pages), found {self.max_pages}")


@dataclass(frozen=True)
class RunConfig:
    """The effective configuration of a run."""

    run: RunParams = field(default_factory=RunParams)
    pipeline: PipelineParams = field(default_factory=PipelineParams)
    ranging: RangingConfig = field(default_factory=RangingConfig)
    fusion: FusionParams = field(default_factory=FusionParams)
    #: the parameters of every other registered stage, by its section (``[median]``)
    stages: Mapping[str, Any] = field(default_factory=lambda: _stage_params({}, ""))

    def params_for(self, section: str) -> Any:
        """A stage's parameters by its section: ``ranging``, ``fusion.lsq``, ``median``."""
        head, _, rest = section.partition(".")
        if head in self.stages:
            return self.stages[head]
        value: Any = getattr(self, head)
        for part in rest.split(".") if rest else ():
            value = getattr(value, part)
        return value

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict (for run.json and ``coopproc config``)."""
        out = {
            "run": to_table(self.run),
            "pipeline": to_table(self.pipeline),
            "ranging": to_table(self.ranging),
            "fusion": to_table(self.fusion),
        }
        out.update({name: to_table(params) for name, params in self.stages.items()})
        return out


#: Sections read by the run itself; every other stage section comes from the registry.
_OWN_SECTIONS: tuple[str, ...] = ("run", "pipeline", "ranging", "fusion")


def _extra_sections() -> dict[str, type]:
    """Top-level sections of the registered stages beyond the ones RunConfig names."""
    out: dict[str, type] = {}
    sections = [(s.section, s.params_type) for s in RANGE_STAGES.values()]
    sections += [(s.section, s.params_type) for s in POSITION_STAGES.values()]
    for section, params_type in sections:
        if "." not in section and section not in _OWN_SECTIONS:
            out[section] = params_type
    return out


def _stage_params(table: Mapping[str, Any], where: str) -> dict[str, Any]:
    return {
        name: from_table(cls, table.get(name), f"{where} [{name}]".strip())
        for name, cls in _extra_sections().items()
    }


#: Top-level sections a run config may have (``[locate]`` is read by ``coopproc locate``
#: and only checked here, so that one file can configure both commands).
SECTIONS: tuple[str, ...] = (*_OWN_SECTIONS, *_extra_sections(), "locate")


def run_config_from_toml(table: Mapping[str, Any], where: str = "run config") -> RunConfig:
    """Build the :class:`RunConfig` from a parsed TOML document."""
    check_keys(table, SECTIONS, where)
    for name, value in table.items():
        if not isinstance(value, Mapping):
            raise ConfigError(f"{where}: '{name}' must be a table ([{name}])")
    if "locate" in table:
        from coopproc.stages.particle.locate import locate_params

        locate_params(table["locate"], f"{where} [locate]")
    return RunConfig(
        run=from_table(RunParams, table.get("run"), f"{where} [run]"),
        pipeline=from_table(PipelineParams, table.get("pipeline"), f"{where} [pipeline]"),
        stages=_stage_params(table, where),
        ranging=ranging_config_from_toml(table, where),
        fusion=fusion_params_from_toml(table, where),
    )


def load_run_config(path: str | Path | None) -> RunConfig:
    """Read a run-config TOML file; ``None`` gives the defaults."""
    if path is None:
        return RunConfig()
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as err:
        raise ConfigError(f"{p}: cannot read the config file ({err.strerror})") from err
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{p}: not valid TOML ({err})") from err
    return run_config_from_toml(table, where=str(p))
