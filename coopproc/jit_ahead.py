"""Compile the later kernels of a cold ``coopproc run`` in a second process, meanwhile.

numba compiles in the calling thread, under a global lock, each kernel when it is first
called: a cold run of ``sample_logs`` spends ~30 s CPU compiling, one kernel after the
other, on one CPU (issue 32 part 6). The kernels are independent, though, and numba's
on-disk cache is shared by processes (each compile is written to a temporary file and
renamed into place; a dispatcher looks the cache up on disk when it meets a new
signature). So when :func:`coopproc.jit_cache.cold_kernels` finds kernels of
:data:`AHEAD` not compiled, :func:`compile_ahead` starts ``python -m coopproc.jit_ahead``,
which compiles them, with the signatures a run calls them with, into the same cache,
while the run compiles and runs its first kernels (the fusion's ``ekf_forward`` and the
smoother's, ~17 s CPU): by the time the run reaches the ranging stage, the figures' track
kernels and the CSV writer, they are on disk and loaded (a few ms each). The compiled
code is the same (same numba, same flags, same machine), so are the outputs.

The split follows the order a run calls the kernels (:data:`coopproc.jit_cache.RUN_KERNELS`,
CPU seconds of their compiles): the run itself compiles the fusion's (``ekf_forward`` 10.7,
the smoother's 5.5), the second process the rest in the order they are needed (the
ranging stage's 9.5 first, then the positions table, the figures' track kernels and the
CSV writer, 5.6), about 17 s either side on two CPUs instead of 33 s on one. A kernel the
run reaches before the second process wrote it is compiled by the run as well (the same
code twice; nothing is wrong, only that CPU second spent twice). The second process is
not started with one CPU (nothing to gain) and is stopped when the run ends (a compile it
had not finished is not written; numba writes each cache file under a temporary name and
renames it, so none is left half-written).

:data:`AHEAD`'s signatures are those a run of ``sample_logs`` compiles (every kernel has
one; tests/test_jit_cache.py checks that they still are), in a short code: ``f8``,
``i8``, ``i4``, ``i1``, ``u8``, ``u1``, ``b1`` for float64 ... bool scalars, ``f8[2]``
for a C-contiguous 2-d array of float64, a trailing ``r`` for a read-only one, and
``module.Class(...)`` for a NamedTuple of the types inside the parentheses.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import subprocess
import sys
from collections.abc import Iterator, Sequence

__all__ = ["AHEAD", "compile_ahead", "signature"]

#: (module, kernel, signature code) the second process compiles, in this order.
AHEAD: tuple[tuple[str, str, str], ...] = (
    ("coopproc.stages.ranging.nlos_kernel", "filter_kernel",
     "coopproc.stages.ranging.nlos_types.FilterSeries(f8[1] f8[1] f8[1] f8[1] f8[1] f8[1] "
     "i1[1] f8[1]) coopproc.stages.ranging.nlos_types.FilterSettings(f8 f8 f8 b1 f8 b1 f8 "
     "f8 f8 f8 i8 i8 i8 f8 i8 b1 f8 f8 f8)"),
    ("coopproc.stages.ranging.di", "_smooth_kernel", "f8[1] f8[1] f8[1] f8[1] f8[1] f8 f8"),
    ("coopproc.stages.ranging.jump", "level_step", "f8[1] f8[1] i8 f8"),
    ("coopproc.run.positions_table", "_found_merged", "f8[1] f8[1]"),
    ("coopproc.report.track_kernels", "run_starts", "i1[1]r i1[1]r"),
    ("coopproc.report.track_kernels", "error_norms", "f8[2] f8[2]"),
    ("coopproc.report.track_kernels", "path_length", "f8[2]"),
    ("coopproc.report.track_kernels", "segment_ends", "f8[1] f8"),
    ("coopproc.report.track_kernels", "segment_errors", "f8[2] f8[2] i8[1]"),
    ("coopproc.io.csv_fast", "_any_slow", "f8[1]r"),
    ("coopproc.io.csv_fast", "_format_rows",
     "i8 i8[1] i8[1] f8[2] i8[2] i8[2] u1[1]r i8[1] u1[1] i8[1]"),
)  # fmt: skip

_SCALARS = {
    "f8": "float64",
    "i8": "int64",
    "i4": "int32",
    "i1": "int8",
    "u8": "uint64",
    "u1": "uint8",
    "b1": "boolean",
}


def signature(code: str) -> tuple[object, ...]:
    """The numba argument types of a signature code (module docstring)."""
    items, rest = _items(code.replace("(", " ( ").replace(")", " ) ").split())
    if rest:
        raise ValueError(f"unbalanced ')' in signature code {code!r}")
    return tuple(items)


def _items(tokens: list[str]) -> tuple[list[object], list[str]]:
    """The types of ``tokens`` up to a closing ``)`` (and the tokens after it). A name
    followed by ``(`` is a NamedTuple class (``module.Class``) of the types inside."""
    from numba.core import types

    out: list[object] = []
    while tokens:
        token, tokens = tokens[0], tokens[1:]
        if token == ")":
            return out, tokens
        if tokens and tokens[0] == "(":
            module, _, name = token.rpartition(".")
            cls = getattr(importlib.import_module(module), name)
            fields, tokens = _items(tokens[1:])
            same = all(f == fields[0] for f in fields)
            out.append(
                types.NamedUniTuple(fields[0], len(fields), cls)
                if same
                else types.NamedTuple(fields, cls)
            )
            continue
        name, _, dims = token.partition("[")
        dtype = getattr(types, _SCALARS[name])
        if not dims:
            out.append(dtype)
            continue
        ndim, _, flags = dims.partition("]")
        out.append(types.Array(dtype, int(ndim), "C", readonly=flags == "r"))
    return out, tokens


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def compile_ahead(cold: Sequence[tuple[str, str, float]] | None) -> Iterator[bool]:
    """Compile the kernels of :data:`AHEAD` that are in ``cold`` (from
    :func:`~coopproc.jit_cache.cold_kernels`) in a second process while the body runs;
    it is stopped when the body ends. Yields whether one was started."""
    names = {(m, k) for m, k, _ in cold or ()}
    todo = [f"{m}:{k}" for m, k, _ in AHEAD if (m, k) in names]
    if not todo or _cpus() < 2:
        yield False
        return
    try:
        child = subprocess.Popen(
            [sys.executable, "-P", "-m", "coopproc.jit_ahead", *todo],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:  # no interpreter to start (an embedded Python): the run compiles all
        yield False
        return
    try:
        yield True
    finally:
        if child.poll() is None:
            child.terminate()
        child.wait()


def main(argv: Sequence[str]) -> int:
    """Compile ``module:kernel`` of :data:`AHEAD` for each argument, in order."""
    codes = {f"{m}:{k}": code for m, k, code in AHEAD}
    failed = 0
    for name in argv:
        module, _, kernel = name.partition(":")
        try:
            getattr(importlib.import_module(module), kernel).compile(signature(codes[name]))
        except Exception as err:  # the run compiles it itself then
            print(f"{name}: {type(err).__name__}: {err}", file=sys.stderr)
            failed += 1
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
