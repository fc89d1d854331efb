"""`coopproc batch --scheduler` on a real two-process Dask cluster, as a user's would be
(issue 35 part 3): the sessions run on the cluster's worker processes, not here, and
their tables are byte for byte those of `coopproc run`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import dask
import pytest
from click.testing import CliRunner

from coopproc.cli import main


def _simulate(path: Path, seed: int) -> None:
    args = ["simulate", str(path), "--scenario", "paper-table1", "--seed", str(seed)]
    res = CliRunner().invoke(main, [*args, "--duration", "40"])
    assert res.exit_code == 0, res.output


@pytest.mark.slow  # 46 s measured on the shared 2-core machine beside a campaign
def test_two_sessions_run_on_the_two_workers_of_a_cluster_like_coopproc_run(
    tmp_path: Path,
) -> None:
    from distributed import Client, LocalCluster
    from distributed.diagnostics.plugin import SchedulerPlugin

    sessions = [tmp_path / f"s{seed}" for seed in (3, 4)]
    for seed, path in zip((3, 4), sessions, strict=True):
        _simulate(path, seed)

    class WhereRun(SchedulerPlugin):
        """Which worker finished each task (the scheduler's own record)."""

        def __init__(self) -> None:
            self.ran: dict[str, str] = {}

        def transition(self, key: Any, start: str, finish: str, *args: Any, **kw: Any) -> None:
            if start == "processing" and finish == "memory":
                self.ran[str(key)] = str(kw.get("worker"))

    where = WhereRun()
    root = tmp_path / "root"
    # one task per worker at a time: the two sessions go to the two idle workers
    with (
        dask.config.set({"distributed.scheduler.worker-saturation": 1.0}),
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": ":0"},
        ) as cluster,
        Client(cluster) as client,
    ):
        cluster.scheduler.add_plugin(where)
        pids = client.run(os.getpid)  # worker address -> its process id
        scheduler = cluster.scheduler_address
        res = CliRunner().invoke(
            main,
            [
                "batch",
                *map(str, sessions),
                "-o",
                str(root),
                "--no-figures",
                "--scheduler",
                scheduler,
            ],
        )
    assert res.exit_code == 0, res.output
    assert "2 of 2 sessions processed" in res.output
    ran = {k: w for k, w in where.ran.items() if k.startswith("run_one-")}
    assert len(ran) == 2
    assert set(ran.values()) == set(pids)  # both workers, one session each
    assert os.getpid() not in pids.values() and len(set(pids.values())) == 2
    for path in sessions:  # nothing depends on the worker that ran it
        single = tmp_path / f"single_{path.name}"
        res = CliRunner().invoke(main, ["run", str(path), "-o", str(single), "--no-figures"])
        assert res.exit_code == 0, res.output
        tables = sorted(p.name for p in single.glob("*.csv"))
        assert {"metrics.csv", "positions.csv", "ranges.csv"} <= set(tables)
        assert sorted(p.name for p in (root / path.name).glob("*.csv")) == tables
        for name in tables:
            assert (root / path.name / name).read_bytes() == (single / name).read_bytes(), name


@pytest.mark.parametrize(
    ("size", "error"),
    [
        ("lots", "error: --worker-memory 'lots': not a size; expected e.g. 3GB, 1.5GiB or 800MB"),
        ("0", "error: --worker-memory '0': must be above 0 (e.g. 3GB)"),
    ],
)
def test_an_unparsable_worker_memory_is_one_line_before_the_work(
    tmp_path: Path, size: str, error: str
) -> None:
    root = tmp_path / "root"
    res = CliRunner().invoke(
        main, ["batch", str(tmp_path / "s"), "-o", str(root), "--worker-memory", size]
    )
    assert res.exit_code == 1, res.output
    assert res.output == error + "\n"
    assert not root.exists()


@pytest.mark.slow  # 29 s measured: a 1 h simulation, its run until the kill, a 40 s session
def test_a_session_over_its_worker_memory_fails_in_one_line_and_the_other_runs(
    tmp_path: Path,
) -> None:
    """A worker that passes 95 % of ``--worker-memory`` is terminated by its nanny: that
    session fails with one line naming the limit, the other session runs, nothing of the
    killed one is left, and Dask's own log of the kill does not reach the terminal. Run
    as a user would (a process of its own: Dask's log handlers write to the real stderr).
    500 MB (terminated above 475 MB), measured here with single-session batches: the
    40 s session peaks at 0.33-0.38 GB in a worker (killed at a 350 MB limit, not at
    400 MB), the 10 x 1 h one at 0.57-0.67 GB (killed at 600 MB, not at 700 MB)."""
    import json
    import subprocess
    import sys

    small, big, root = tmp_path / "small", tmp_path / "big", tmp_path / "root"
    _simulate(small, 3)
    res = CliRunner().invoke(
        main, ["simulate", str(big), "--scenario", "large", "--seed", "0", "--duration", "3600"]
    )
    assert res.exit_code == 0, res.output
    args = [str(small), str(big), "-o", str(root), "--no-figures", "--workers", "2"]
    done = subprocess.run(
        [sys.executable, "-m", "coopproc", "batch", *args, "--worker-memory", "500MB"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 1, done.stdout + done.stderr
    said = done.stdout + done.stderr
    line = (
        f"error: {big}: its Dask worker was terminated for using more than 95% of its "
        "memory limit of 0.50 GB ("
    )
    assert said.count(line) == 1, said
    assert "raise --worker-memory or use fewer --workers" in said
    assert "1 of 2 sessions processed" in said
    assert "distributed." not in said and "Traceback" not in said, said  # Dask's own log
    assert (root / "small" / "metrics.csv").is_file()
    assert not (root / "big").exists()  # nothing of the killed session
    listed = {e["output"]: e for e in json.loads((root / "batch.json").read_text())["sessions"]}
    assert listed["small"]["ok"] and not listed["big"]["ok"]
    assert listed["big"]["error"].startswith(line.removeprefix("error: "))
