"""run_pipeline lets go of the session's samples once the fusions and the ranging have run
(issue 11): the range rows at once, each platform's navigation and reference once its
positions.csv rows are written; nothing after that holds them, and the tables are those of
a run that keeps them."""

from __future__ import annotations

import gc
import weakref

import pandas as pd

from coopproc.checks.coverage import prepare_run
from coopproc.run.config import RunConfig
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate


def _session():
    session, _ = prepare_run(simulate("paper-experiment", seed=0, duration_s=60.0).session)
    return session


def test_the_samples_are_freed_when_spent_and_the_tables_unchanged() -> None:
    holder = [_session()]
    nav = weakref.ref(next(iter(holder[0].nav.values())))
    reference = weakref.ref(next(iter(holder[0].reference.values())))
    rows = weakref.ref(holder[0].ranges.frame)
    freed: list[bool] = []

    def spent() -> None:
        holder[0] = holder[0].without_samples()
        gc.collect()
        freed.append(rows() is None)

    lean = run_pipeline(holder[0], RunConfig(), samples_spent=spent)
    assert freed == [True]  # called once, and nothing in the pipeline held the range rows
    gc.collect()
    assert nav() is None and reference() is None  # positions.csv's table let them go
    kept = run_pipeline(_session(), RunConfig())
    for name in ("ranges", "positions", "metrics", "position_metrics", "nlos_events"):
        pd.testing.assert_frame_equal(getattr(lean.result, name), getattr(kept.result, name))
