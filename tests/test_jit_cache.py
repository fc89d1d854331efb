"""The first run says that it compiles (coopproc.jit_cache): cold and warm told apart from
numba's own cache index, and the kernel list is the one a run calls."""

from __future__ import annotations

import os
import subprocess
import sys
import types
from pathlib import Path

import pytest
from click.testing import CliRunner
from numba.core.registry import CPUDispatcher

from coopproc.cli import main
from coopproc.jit_cache import RUN_KERNELS

SAMPLE = Path(__file__).resolve().parents[1] / "sample_logs"

_COLD_THEN_WARM = """
import numpy as np
from coopproc.jit_cache import compile_note
from coopproc.io.csv_fast import _any_slow
kernel = [("coopproc.io.csv_fast", "_any_slow", 0.1)]
print(compile_note(kernel))
_any_slow(np.zeros(3))
print(compile_note(kernel))
"""


def test_an_empty_cache_is_said_and_a_compiled_kernel_is_not(tmp_path: Path) -> None:
    """With an empty NUMBA_CACHE_DIR the kernel is cold (the note); once it has been
    called its compile is in the cache and nothing is said."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    out = subprocess.run(
        [sys.executable, "-c", _COLD_THEN_WARM], env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == [
        "compiling the numerical kernels (once after install, a few seconds)",
        "None",
    ]


def _signatures() -> dict[str, int]:
    """Compiled specialisations of every coopproc numba kernel in this process."""
    out = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("coopproc"):
            continue
        for attr, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.py_func.__module__ == name:
                out[f"{name}:{attr}"] = len(value.signatures)
    return out


def _callees(listed: set[str]) -> set[str]:
    """The compiled functions the listed kernels call, transitively (a kernel's callees
    are compiled with it when it is compiled, not loaded from the cache: with an empty
    cache they gain signatures without being called from Python)."""
    found: set[str] = set()
    todo = []
    for key in listed:
        module, name = key.split(":")
        todo.append(getattr(sys.modules[module], name))
    while todo:
        func = todo.pop().py_func
        names: list[str] = []
        codes = [func.__code__]
        while codes:  # the function's own names and those of its nested functions
            code = codes.pop()
            names += code.co_names
            codes += [c for c in code.co_consts if isinstance(c, types.CodeType)]
        scopes = [func.__globals__]
        scopes += [vars(v) for v in func.__globals__.values() if isinstance(v, types.ModuleType)]
        for name in names:
            for scope in scopes:
                value = scope.get(name)
                if isinstance(value, CPUDispatcher):
                    key = f"{value.py_func.__module__}:{value.py_func.__name__}"
                    if key not in found:
                        found.add(key)
                        todo.append(value)
    return found


def test_a_run_calls_no_kernel_outside_the_list(tmp_path: Path) -> None:
    """Every kernel a run of sample_logs calls from Python is in RUN_KERNELS or is a
    compiled callee of a listed one (compiled and cached with it), so the cold check sees
    them all; and each listed one is called (the list is not stale). The same with a
    cold or a warm cache."""
    if not SAMPLE.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    before = _signatures()
    out = tmp_path / "run"
    result = CliRunner().invoke(
        main, ["run", str(SAMPLE), "-o", str(out), "--no-figures", "-q", "--force"]
    )
    assert result.exit_code == 0, result.output
    after = _signatures()
    called = {k for k, n in after.items() if n > before.get(k, 0)}
    listed = {f"{m}:{k}" for m, k, _ in RUN_KERNELS}
    assert called - listed - _callees(listed) == set()
    assert {k for k in listed if after.get(k, 0) == 0} == set()


def test_the_kernels_compiled_ahead_are_called_with_their_listed_signatures(
    tmp_path: Path,
) -> None:
    """A run of sample_logs calls each kernel of jit_ahead.AHEAD with the signature the
    second process compiles (else it compiles for nothing and the run compiles again)."""
    if not SAMPLE.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    import importlib

    from coopproc.jit_ahead import AHEAD, signature

    result = CliRunner().invoke(
        main, ["run", str(SAMPLE), "-o", str(tmp_path / "run"), "-q", "--force"]
    )
    assert result.exit_code == 0, result.output
    listed = {(m, k) for m, k, _ in RUN_KERNELS}
    for module, kernel, code in AHEAD:
        assert (module, kernel) in listed
        compiled = getattr(importlib.import_module(module), kernel).signatures
        assert signature(code) in [tuple(s) for s in compiled], f"{module}.{kernel}"


_LOAD_READONLY = """
import numpy as np
from coopproc.io.csv_fast import _any_slow
values = np.zeros(3)
values.flags.writeable = False
_any_slow(values)
print(sum(_any_slow.stats.cache_hits.values()), sum(_any_slow.stats.cache_misses.values()))
"""


def test_a_kernel_compiled_ahead_is_loaded_by_the_run_not_compiled_again(
    tmp_path: Path,
) -> None:
    """``python -m coopproc.jit_ahead`` writes the compile into the cache under the key
    the run's call looks up: the run's process loads it (a cache hit, no miss)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    ahead = subprocess.run(
        [sys.executable, "-m", "coopproc.jit_ahead", "coopproc.io.csv_fast:_any_slow"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert ahead.returncode == 0, ahead.stderr
    out = subprocess.run(
        [sys.executable, "-c", _LOAD_READONLY], env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1", "0"]


def test_the_note_says_the_longer_share_when_a_second_process_compiles() -> None:
    from coopproc.jit_ahead import AHEAD
    from coopproc.jit_cache import AHEAD_START_S, compile_note

    ahead = {(m, k) for m, k, _ in AHEAD}
    here = sum(s for m, k, s in RUN_KERNELS if (m, k) not in ahead)
    there = sum(s for m, k, s in RUN_KERNELS if (m, k) in ahead)
    assert here > there + AHEAD_START_S  # the fusion's kernels are the longer share
    alone = compile_note(cold=RUN_KERNELS)
    together = compile_note(cold=RUN_KERNELS, ahead=ahead)
    assert alone == "compiling the numerical kernels (once after install, about 45 s)"
    assert together == "compiling the numerical kernels (once after install, about 30 s)"
    assert compile_note(cold=[]) is None


@pytest.mark.slow
def test_a_cold_run_with_kernels_compiled_ahead_writes_the_warm_runs_files(
    tmp_path: Path,
) -> None:
    """An empty numba cache: the run says the longer share (about 30 s, not 40), the
    second process compiles the later kernels, and the tables are byte for byte those
    of a run with the cache warm (the same compiled code)."""
    if not SAMPLE.is_dir():
        pytest.skip("no sample_logs/ in this checkout")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    runs = {}
    for name in ("cold", "warm"):
        out = tmp_path / name
        done = subprocess.run(
            [sys.executable, "-m", "coopproc", "run", str(SAMPLE), "-o", str(out),
             "--no-figures"],
            env=env, capture_output=True, text=True,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        runs[name] = (out, done.stderr)
    note = "compiling the numerical kernels (once after install, about 30 s)"
    assert note in runs["cold"][1] and "compiling" not in runs["warm"][1]
    cold, warm = runs["cold"][0], runs["warm"][0]
    tables = sorted(p.name for p in cold.glob("*.csv"))
    assert tables and tables == sorted(p.name for p in warm.glob("*.csv"))
    for name in tables:
        assert (cold / name).read_bytes() == (warm / name).read_bytes(), name


def test_the_second_process_is_started_for_cold_kernels_and_stopped_after(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import coopproc.jit_ahead as ahead

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    started: list[subprocess.Popen[bytes]] = []
    real = subprocess.Popen

    def popen(*args: object, **kwargs: object) -> subprocess.Popen[bytes]:
        started.append(real(*args, **kwargs))  # type: ignore[call-overload]
        return started[-1]

    monkeypatch.setattr(ahead.subprocess, "Popen", popen)
    cold = [("coopproc.io.csv_fast", "_format_rows", 1.9)]
    with ahead.compile_ahead(cold) as running:
        assert running and len(started) == 1
        assert started[0].args[-1] == "coopproc.io.csv_fast:_format_rows"
    assert started[0].poll() is not None  # stopped (or done) when the run ends
    with ahead.compile_ahead([("coopproc.stages.fusion.ekf", "ekf_forward", 18.9)]) as running:
        assert not running  # the run's own share: nothing to start
    monkeypatch.setattr(ahead, "_cpus", lambda: 1)
    with ahead.compile_ahead(cold) as running:
        assert not running  # one CPU: nothing to gain
    monkeypatch.setattr(ahead, "_cpus", lambda: 2)
    monkeypatch.setattr(ahead.sys, "executable", str(tmp_path / "no-python"))
    with ahead.compile_ahead(cold) as running:
        assert not running  # no interpreter to start: the run compiles everything
    assert len(started) == 1
