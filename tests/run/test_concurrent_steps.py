"""Independent position steps at once (fusion (rn) and fusion (di) in a forked child):
the grouping, when forking is allowed, the transport of the product and the errors."""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import signal
import threading
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.checks.coverage import prepare_run
from coopproc.cli import main
from coopproc.errors import CoopprocError, InputError, StageError
from coopproc.io import read_session
from coopproc.model import Session
from coopproc.run import concurrent_steps
from coopproc.run.chain import PipelineParams, resolve
from coopproc.run.concurrent_steps import (
    BYTES_PER_ROW,
    MAX_EXTRA_BYTES,
    MIN_ROWS,
    group_label,
    group_steps,
    run_concurrently,
    workers,
)
from coopproc.run.config import RunConfig, RunParams, run_config_from_toml
from coopproc.run.pipeline import run_pipeline
from coopproc.sim import simulate, write_simulation
from coopproc.stages import registry

FORK = "fork" in multiprocessing.get_all_start_methods()
needs_fork = pytest.mark.skipif(not FORK, reason="no fork on this platform")


def _groups(size: int, **pipeline: object) -> list[str]:
    params = run_config_from_toml({"pipeline": pipeline}).pipeline
    steps = resolve(params)
    groups = group_steps(steps, size)
    assert [s for g in groups for s in g] == list(steps)  # same steps, same order
    return [group_label(g) for g in groups]


def test_the_fusions_of_the_processed_sets_go_together() -> None:
    assert _groups(2) == ["fusion (observed)", "ranging (rn, di)", "fusion (rn, di)"]
    assert _groups(1) == ["fusion (observed)", "ranging (rn, di)", "fusion (rn)", "fusion (di)"]
    # at most two a group, in chain order
    assert _groups(2, ranges=["di", "median", "rn"]) == [
        "median (median)",
        "fusion (observed)",
        "ranging (di, rn)",
        "fusion (di, median)",
        "fusion (rn)",
    ]
    assert _groups(2, ranges=["median"], positions=["lsq"]) == [
        "median (median)",
        "lsq (observed, median)",
    ]
    assert _groups(2, ranges=[], positions=["fusion", "lsq"]) == [
        "fusion (observed), lsq (observed)"
    ]


def test_a_step_that_needs_the_one_before_waits_for_it() -> None:
    # fusion (median) takes fusion (observed)'s product: never at the same time
    assert _groups(2, ranges=["median"]) == [
        "median (median)",
        "fusion (observed)",
        "fusion (median)",
    ]


@needs_fork
def test_when_forking_is_allowed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(concurrent_steps, "_cpus", lambda: 2)
    monkeypatch.setattr(concurrent_steps, "_available_bytes", lambda: 2 * BYTES_PER_ROW * MIN_ROWS)
    assert workers("auto", MIN_ROWS) == 2
    assert workers("auto", MIN_ROWS - 1) == 1  # a small session: not worth a fork
    assert workers("auto", MIN_ROWS + 1) == 1  # a second fusion would not fit in memory
    assert workers(True, MIN_ROWS + 1) == 2  # asked for: the user knows
    monkeypatch.setattr(concurrent_steps, "_available_bytes", lambda: None)  # unknown
    assert workers("auto", MIN_ROWS + 1) == 2
    # a second fusion that would add more than MAX_EXTRA_BYTES to the peak: not by default
    biggest = MAX_EXTRA_BYTES // BYTES_PER_ROW
    assert workers("auto", biggest) == 2
    assert workers("auto", biggest + 1) == 1
    assert workers(True, biggest + 1) == 2
    assert workers(True, 10) == 2
    assert workers(False, MIN_ROWS) == 1
    monkeypatch.setattr(concurrent_steps, "_cpus", lambda: 1)
    assert workers("auto", MIN_ROWS) == 1
    assert workers(True, 10) == 2  # asked for: one CPU is not a reason to refuse
    # a thread other than the main one, a daemonic process (coopproc batch's workers)
    seen: list[int] = []
    thread = threading.Thread(target=lambda: seen.append(workers(True, MIN_ROWS)))
    thread.start()
    thread.join()
    assert seen == [1]
    daemon = SimpleNamespace(daemon=True)
    monkeypatch.setattr(multiprocessing, "current_process", lambda: daemon)
    assert workers(True, MIN_ROWS) == 1


def test_no_fork_means_one_after_the_other(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(multiprocessing, "get_all_start_methods", lambda: ["spawn"])
    assert workers(True, MIN_ROWS) == 1


def test_the_config_switch() -> None:
    assert RunConfig().run.parallel_fusion == "auto"
    assert run_config_from_toml({"run": {"parallel_fusion": False}}).run.parallel_fusion is False
    assert run_config_from_toml({"run": {"parallel_fusion": True}}).run.parallel_fusion is True
    # every accepted form is named: bool | Literal["auto"]
    with pytest.raises(Exception, match=r"parallel_fusion: expected true or false.*or .*'auto'"):
        run_config_from_toml({"run": {"parallel_fusion": "yes"}})


def _product() -> dict[str, Any]:
    rng = np.random.default_rng(3)
    big = rng.normal(size=(20_000, 3))
    return {
        "pid": os.getpid(),
        "big": big,
        "strided": big[::7, 1],  # not contiguous: pickled in band
        "empty": np.zeros((0, 3)),
        "frame": pd.DataFrame({"t": np.arange(5.0), "id": list("abcde")}),
    }


@needs_fork
def test_a_child_gives_back_what_it_computed() -> None:
    here, there = run_concurrently([_product, _product], ["a", "b"])
    assert here["pid"] == os.getpid() != there["pid"]  # really another process
    for key in ("big", "strided", "empty"):
        assert there[key].dtype == here[key].dtype
        np.testing.assert_array_equal(there[key], here[key])
    pd.testing.assert_frame_equal(there["frame"], here["frame"])


def _fails() -> None:
    raise StageError("fusion: platform B has no navigation in the ranges' span")


def _fails_odd() -> None:  # an error whose class needs keyword arguments to rebuild
    raise InputError("nav_B.csv", "time goes backwards", line=12)


def _fails_unpicklable() -> None:  # an error holding what pickle cannot take
    err = StageError("fusion: cannot go on")
    err.hook = lambda: None  # type: ignore[attr-defined]
    raise err


@needs_fork
def test_an_error_in_the_child_reaches_the_caller_as_it_was() -> None:
    with pytest.raises(StageError, match=r"^fusion: platform B has no navigation"):
        run_concurrently([lambda: 1, _fails], ["fusion (rn)", "fusion (di)"])
    # rebuilt with the same message (as itself where tblib's pickling is installed, e.g.
    # after dask was imported; else as a StageError)
    with pytest.raises(CoopprocError) as caught:
        run_concurrently([lambda: 1, _fails_odd], ["fusion (rn)", "fusion (di)"])
    assert str(caught.value) == "nav_B.csv:12: time goes backwards"
    with pytest.raises(StageError) as caught:
        run_concurrently([lambda: 1, _fails_unpicklable], ["fusion (rn)", "fusion (di)"])
    assert str(caught.value) == "fusion: cannot go on"
    assert not hasattr(caught.value, "hook")  # rebuilt, not the original


def _killed() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


@needs_fork
def test_a_killed_child_is_a_clear_error_not_a_hang() -> None:
    with pytest.raises(StageError, match=r"fusion \(di\): the worker process .* SIGKILL"):
        run_concurrently([lambda: 1, _killed], ["fusion (rn)", "fusion (di)"])


@needs_fork
def test_the_child_is_ended_when_the_caller_fails(tmp_path: Path) -> None:
    pid_file = tmp_path / "pid"

    def slow() -> None:
        pid_file.write_text(str(os.getpid()))
        time.sleep(60)

    def broken() -> None:
        while not pid_file.exists() or not pid_file.read_text():
            time.sleep(0.01)
        raise ValueError("caller failed")

    start = time.perf_counter()
    with pytest.raises(ValueError, match="caller failed"):
        run_concurrently([broken, slow], ["a", "b"])
    assert time.perf_counter() - start < 30
    with pytest.raises(ProcessLookupError):  # killed and reaped, not a zombie
        os.kill(int(pid_file.read_text()), 0)


@pytest.fixture(scope="module")
def session_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("concurrent") / "lv"
    sim = simulate("land-vehicle", seed=1, duration_s=30.0, imu_rate_hz=0.0)
    write_simulation(sim, root)
    return root


@pytest.fixture(scope="module")
def session(session_dir: Path) -> Session:
    return prepare_run(read_session(session_dir))[0]


def _run(session: Session, parallel: bool) -> Any:
    # the fusions only (not the anchors' lsq comparison rows)
    pipeline = PipelineParams(anchor_methods=False)
    config = RunConfig(run=RunParams(parallel_fusion=parallel), pipeline=pipeline)
    return run_pipeline(session, config)


@needs_fork
def test_concurrent_and_sequential_give_the_same_products(session: Session) -> None:
    one_by_one, at_once = _run(session, False), _run(session, True)
    assert list(one_by_one.timings_s) == [
        "fusion (observed)",
        "ranging (rn, di)",
        "fusion (rn)",
        "fusion (di)",
        "metrics",
    ]
    assert list(at_once.timings_s) == [
        "fusion (observed)",
        "ranging (rn, di)",
        "fusion (rn, di)",
        "metrics",
    ]
    pd.testing.assert_frame_equal(at_once.result.positions, one_by_one.result.positions)
    pd.testing.assert_frame_equal(
        at_once.result.position_metrics, one_by_one.result.position_metrics
    )
    assert at_once.methods == one_by_one.methods
    assert at_once.notes == one_by_one.notes
    assert at_once.fusion_calibration.keys() == one_by_one.fusion_calibration.keys()
    for method, calibration in one_by_one.fusion_calibration.items():
        assert repr(at_once.fusion_calibration[method]) == repr(calibration)


@needs_fork
def test_a_stage_error_in_the_child_is_one_line_and_a_failed_run(
    session_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    lsq = registry.POSITION_STAGES["lsq"]

    def run(position_input: Any, params: Any) -> Any:
        if position_input.range_set == "median":  # the step the child runs
            raise StageError("lsq: broken on purpose for the test")
        return lsq.run(position_input, params)

    monkeypatch.setitem(registry.POSITION_STAGES, "lsq", dataclasses.replace(lsq, run=run))
    config = tmp_path / "run.toml"  # lsq (observed) here, lsq (median) in the child
    config.write_text(
        '[run]\nparallel_fusion = true\n[pipeline]\nranges = ["median"]\npositions = ["lsq"]\n'
    )
    args = ["run", str(session_dir), "-o", str(tmp_path / "out"), "-c", str(config)]
    res = CliRunner().invoke(main, [*args, "--no-figures", "-q"])
    assert res.exit_code == 1
    assert res.output.strip() == "error: lsq: broken on purpose for the test"
