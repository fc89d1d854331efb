"""When a leader's own fix is an observation ([fusion] leader_fix), and with what weight."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import pytest

from coopproc.checks.coverage import prepare_run
from coopproc.io import read_session
from coopproc.model import pair_name
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.fusion.nav_span import epoch_bounds
from coopproc.stages.fusion.observations import leader_fix_epochs, pooled_counts
from coopproc.stages.shared.data import pair_names

SAMPLE = Path(__file__).resolve().parents[3] / "sample_logs"


def _session(nav_times: dict[str, list[float]]) -> Any:
    return SimpleNamespace(
        nav={p: SimpleNamespace(time_s=np.array(t)) for p, t in nav_times.items()}
    )


def test_nav_rate_fix_at_the_first_epoch_at_or_after_each_nav_sample() -> None:
    epochs = np.array([0.0, 0.03, 0.06, 0.1, 0.13, 0.2, 0.25])
    session = _session({"B": [0.0, 0.1, 0.2, 0.3], "L": [0.05, 0.21]})
    fixes = leader_fix_epochs(session, ["B", "L"], epochs, every_epoch=False)
    assert fixes[0].tolist() == [True, False, False, True, False, True, False]
    # inside its navigation (0.05-0.21 s) only (issue 29): the first epoch there, 0.06, is
    # also where 0.05 goes; 0.21 -> 0.25 is after its navigation ends: no fix
    assert fixes[1].tolist() == [False, False, True, False, False, False, False]
    assert leader_fix_epochs(session, ["B"], epochs, every_epoch=True).all()


def test_every_epoch_fix_only_inside_the_leaders_navigation() -> None:
    epochs = np.array([0.0, 0.03, 0.06, 0.1, 0.13, 0.2, 0.25])
    session = _session({"B": [0.0, 0.3], "L": [0.05, 0.2]})
    fixes = leader_fix_epochs(session, ["B", "L"], epochs, every_epoch=True)
    assert fixes[0].all()
    assert fixes[1].tolist() == [False, False, True, True, True, True, False]
    # a leader whose navigation holds no epoch: never a fix
    late = _session({"L": [0.3, 0.4]})
    assert not leader_fix_epochs(late, ["L"], epochs, every_epoch=False).any()


def test_leader_fix_must_be_pooled_epoch_or_nav() -> None:
    assert FusionParams().leader_fix == "pooled"
    assert FusionParams(leader_fix="nav").leader_fix == "nav"
    with pytest.raises(ValueError, match="leader_fix"):
        FusionParams(leader_fix="sometimes")


def test_pair_names_equals_pair_name_row_by_row() -> None:
    rng = np.random.default_rng(4)
    ids = np.array(["A", "B", "tb10", "tb2", "x-1", "C"], dtype=object)
    first = ids[rng.integers(0, ids.shape[0], 500)]
    second = ids[rng.integers(0, ids.shape[0], 500)]
    got = pair_names(pd.Series(first), second)
    assert list(got) == [pair_name(str(a), str(b)) for a, b in zip(first, second, strict=True)]
    assert pair_names([], []).shape == (0,)


def test_a_pooled_fix_stands_for_the_epochs_up_to_the_next() -> None:
    fixes = np.array([True, False, False, True, False, True, False])
    # epochs 0-2, 3-4 and 5-6 (the span ends at 7): what "epoch" applies there
    assert pooled_counts(fixes, 7).tolist() == [3, 2, 2]
    assert pooled_counts(fixes, 6).tolist() == [3, 2, 1]
    assert pooled_counts(np.zeros(4, dtype=bool), 4).tolist() == []


def test_the_pooled_fix_gives_the_every_epoch_solution_with_fewer_updates() -> None:
    # sample_logs: 3 pairs polled in turn, so the epochs (the range times) are faster than
    # the leader B's navigation; the pooled fix carries each nav sample's repeated
    # information in one update
    session, _ = prepare_run(read_session(SAMPLE))
    ranges = session.ranges.frame[["time", "from", "to", "range", "sigma"]]
    fused = {
        mode: fuse(session, ranges, FusionParams(leader_fix=mode), smoothed_sigma=False)
        for mode in ("epoch", "pooled")
    }
    epochs = fused["epoch"].epochs_s
    k_lo, k_hi = epoch_bounds(session, ["B"], epochs)
    placed = leader_fix_epochs(session, ["B"], epochs, every_epoch=False)[0]
    counts = pooled_counts(placed, int(k_hi[0]))
    assert counts.sum() == k_hi[0] - k_lo[0]  # every epoch's fix, pooled
    assert placed.sum() < 0.6 * (k_hi[0] - k_lo[0]) and counts.max() >= 2
    for pid in ("A", "B", "C"):
        a, b = fused["epoch"].smoothed[pid].enu_m, fused["pooled"].smoothed[pid].enu_m
        # measured: at most 0.39 mm (B), 0.06 mm (A, C)
        assert np.abs(a - b).max() < 2e-3
