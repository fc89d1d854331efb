"""When a leader's own fix is an observation ([fusion] leader_fix)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import pytest

from coopproc.model import pair_name
from coopproc.stages.fusion.fuse import FusionParams
from coopproc.stages.fusion.observations import leader_fix_epochs
from coopproc.stages.shared.data import pair_names


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


def test_leader_fix_must_be_epoch_or_nav() -> None:
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
