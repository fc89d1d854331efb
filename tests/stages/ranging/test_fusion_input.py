"""The DI range set's fusion input (``[ranging.di] fusion_input``,
stages/ranging/entry.py): the observed ranges less the DI-Based NLOS estimates at the
flagged epochs, while ranges.csv keeps the DI filter's distance."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from coopproc.io.session import read_session
from coopproc.sim import simulate, write_simulation
from coopproc.stages.base import RangeInput
from coopproc.stages.ranging.config import RangingConfig
from coopproc.stages.ranging.entry import ranging_stage
from coopproc.stages.ranging.table import observed_table


def test_the_fusion_takes_the_observed_ranges_less_the_estimates(tmp_path: Path) -> None:
    write_simulation(simulate("paper-experiment", seed=0), tmp_path / "s", force=True)
    session = read_session(tmp_path / "s")
    table = observed_table(session)
    inp = RangeInput(session, table, session.nav, None, None)
    product = ranging_stage(inp, RangingConfig(), ("rn", "di"))
    flag, estimate = product.nlos["di"]
    assert flag.sum() > 50  # the simulated events are found
    observed = table["observed"].to_numpy()
    fused = product.fusion_values["di"]
    np.testing.assert_array_equal(fused[flag == 1], observed[flag == 1] - estimate[flag == 1])
    np.testing.assert_array_equal(fused[flag == 0], observed[flag == 0])
    # the DI output itself is the filter's distance, not that
    assert not np.allclose(product.values["di"], fused)
    config = RangingConfig()
    paper = dataclasses.replace(config, di=dataclasses.replace(config.di, fusion_input="distance"))
    assert ranging_stage(inp, paper, ("rn", "di")).fusion_values == {}
