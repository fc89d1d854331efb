"""Shared test configuration."""

import os

import matplotlib
from hypothesis import settings

matplotlib.use("Agg")

# CI (CI=true) runs the property tests derandomized: the same examples every run, so a
# submission is judged on the code, not on the luck of the draw. Locally they explore.
settings.register_profile("ci", derandomize=True, database=None, deadline=None)
if os.environ.get("CI"):
    settings.load_profile("ci")


def _serialize_numba_compiles() -> None:
    """One process at a time compiles a given numba kernel (issue 35.4).

    On a fresh clone numba's cache is empty, and the two xdist workers reach the same
    kernels in their first files (both run ``coopproc run``): each compiled them, 36 s of
    CPU twice. Here a kernel's compile holds an exclusive lock on a file named after it;
    a worker that waits for the other's compile finds it in numba's on-disk cache
    (``Dispatcher.compile`` looks there first) and loads it instead. Kernels are a call
    graph without cycles and a process locks along its call chain, so two processes
    cannot wait for each other; a kernel already locked by this process (a recursive
    compile) is not locked again. Without ``fcntl`` (not POSIX) nothing changes.
    """
    try:
        import fcntl
        import tempfile
        from pathlib import Path

        from numba.core.dispatcher import Dispatcher
    except ImportError:
        return
    where = Path(tempfile.gettempdir()) / f"coopproc-numba-locks-{os.getuid()}"
    held: set[str] = set()
    compile_ = Dispatcher.compile

    def compile_one_at_a_time(self, sig):  # type: ignore[no-untyped-def]
        name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
        if name in held:
            return compile_(self, sig)
        where.mkdir(exist_ok=True)
        with open(where / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            held.add(name)
            try:
                return compile_(self, sig)
            finally:
                held.discard(name)
                fcntl.flock(lock, fcntl.LOCK_UN)

    Dispatcher.compile = compile_one_at_a_time


_serialize_numba_compiles()
