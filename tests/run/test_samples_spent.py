"""run_pipeline lets go of the session's samples once the fusions and the ranging have run
(issue 11), when the session is handed over in a Held box (memory.py, issue 34): the range
rows at once, each platform's navigation and reference once its positions.csv rows are
written; nothing after that holds them, the box holds the session without them, and the
tables are those of a run that keeps them."""

from __future__ import annotations

import gc
import weakref

import pandas as pd

from coopproc.checks.coverage import prepare_run
from coopproc.memory import Held
from coopproc.run.config import RunConfig
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate


def _session():
    session, _ = prepare_run(simulate("paper-experiment", seed=0, duration_s=60.0).session)
    return session


def test_the_samples_are_freed_when_spent_and_the_tables_unchanged() -> None:
    held = Held(_session())
    nav = weakref.ref(next(iter(held.value.nav.values())))
    reference = weakref.ref(next(iter(held.value.reference.values())))
    rows = weakref.ref(held.value.ranges.frame)
    platforms = tuple(held.value.platforms)
    lean = run_pipeline(held, RunConfig())
    gc.collect()
    assert rows() is None  # nothing in the pipeline held the range rows
    assert nav() is None and reference() is None  # positions.csv's table let them go
    assert not held.value.nav and not held.value.reference  # the box: the session without
    assert tuple(held.value.platforms) == platforms  # ... its samples, the rest kept
    kept_session = _session()
    kept = run_pipeline(kept_session, RunConfig())
    assert kept_session.nav and len(kept_session.ranges) > 0  # a plain session is only read
    for name in ("ranges", "positions", "metrics", "position_metrics", "nlos_events"):
        pd.testing.assert_frame_equal(getattr(lean.result, name), getattr(kept.result, name))
