"""Issue 5 acceptance: cooperative fusion with processed ranges against simulated truth
(paper 000 Table 3), through real files and `coopproc run`."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from tests.e2e.conftest import E2ERun


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_experiment_table3(e2e_runs: Callable[[str, int], E2ERun], seed: int) -> None:
    run = e2e_runs("paper-experiment", seed)
    followers = ["A", "C"]
    for platform in followers:
        nav = run.position(platform, "nav", "mean")
        observed = run.position(platform, "observed", "mean")
        rn = run.position(platform, "rn", "mean")
        di = run.position(platform, "di", "mean")
        print(f"\n{platform}: nav {nav:.3f}  observed {observed:.3f}  rn {rn:.3f}  di {di:.3f}")
        assert di <= 0.7 * observed, (platform, di, observed)
        assert di < rn, (platform, di, rn)
        for method in ("observed", "rn", "di"):
            assert run.position(platform, method, "mean") < nav, (platform, method)
