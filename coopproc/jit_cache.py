"""Whether ``coopproc run`` will compile its numba kernels first, and about how long.

Every kernel is ``@numba.njit(cache=True)``: compiled on its first call after an install
(or a change of its source or of numba), written to numba's on-disk cache (``__pycache__``
next to the module, or ``NUMBA_CACHE_DIR``) and loaded from there by later runs. The
first run of ``coopproc run sample_logs`` after an install spends most of its time
compiling, without this a minute of silence after "prepare" (issue 32).

How "warm" is decided (:func:`cold_kernels`): each kernel the run calls from Python
(:data:`RUN_KERNELS`; their callees are compiled into them and cached with them) has a
numba cache index whose stamp matches its source file and this numba version, and that
index lists at least one compiled specialisation. This asks numba's own cache (its index
file, as numba reads it before it compiles), so it follows numba's rules for staleness;
a marker file written after a successful run would not see an edited kernel, another
``NUMBA_CACHE_DIR`` or a cleared ``__pycache__``. The index is read through numba's
private cache objects: when they are not there (another numba), the state is unknown
and nothing is said.

:data:`RUN_KERNELS` holds, per kernel, the CPU seconds its first compile took in a run
of ``sample_logs`` with an empty cache (numba 0.68, the 2-core machine of issue 32, taken
from numba's compile events: each kernel's compile with the callees compiled first for
it). A cold run's note sums those of the kernels not yet cached, the longer of the two
shares when a second process compiles the later kernels meanwhile (:mod:`coopproc.jit_ahead`);
the wall-clock time is about that on an idle machine and grows with its load.
"""

from __future__ import annotations

import importlib
from collections.abc import Collection, Sequence

__all__ = ["AHEAD_START_S", "RUN_KERNELS", "cold_kernels", "compile_note"]

#: (module, kernel, CPU seconds of its first compile) of every numba kernel a run of
#: ``coopproc run`` calls from Python, in the order a run reaches them (measured on
#: ``sample_logs`` with an empty NUMBA_CACHE_DIR, 48 s CPU for the whole run, 41 s of it
#: compiling; tests/test_jit_cache.py checks that a run calls no other kernel).
RUN_KERNELS: tuple[tuple[str, str, float], ...] = (
    ("coopproc.stages.fusion.range_digest", "_multiset_sums", 0.6),
    ("coopproc.stages.fusion.ekf", "ekf_forward", 18.9),
    # compiled as ekf_forward's callees (their cost is in its), called from Python too
    ("coopproc.stages.fusion.ekf_update", "max_epoch_obs", 0.0),
    ("coopproc.stages.fusion.ekf_update", "epoch_buffers", 0.0),
    ("coopproc.stages.fusion.smoother_rerun", "block_extent", 1.2),
    ("coopproc.stages.fusion.smoother_rerun", "rerun_block", 3.5),
    # measured on its own after rerun_block (their shared filter_epoch compiled), 2026-12-02
    ("coopproc.stages.fusion.smoother_rerun", "refit_checkpoints", 1.4),
    ("coopproc.stages.fusion.smoother", "_backward_block", 3.9),
    ("coopproc.stages.ranging.di", "_smooth_kernel", 1.0),
    ("coopproc.stages.ranging.nlos_kernel", "filter_kernel", 6.3),
    # the two-run combination's level-step test (onerun.py), measured alone 2026-12-07
    ("coopproc.stages.ranging.jump", "level_step", 3.2),
    ("coopproc.run.positions_table", "_found_merged", 0.6),
    ("coopproc.report.track_kernels", "run_starts", 0.5),
    ("coopproc.report.track_kernels", "error_norms", 1.2),
    ("coopproc.report.track_kernels", "path_length", 0.6),
    ("coopproc.report.track_kernels", "segment_ends", 0.3),
    ("coopproc.report.track_kernels", "segment_errors", 0.4),
    ("coopproc.io.csv_fast", "_any_slow", 0.1),
    ("coopproc.io.csv_fast", "_format_rows", 1.9),
)


def _is_cached(dispatcher: object) -> bool | None:
    """Whether numba's on-disk cache holds a current compile of ``dispatcher`` (None:
    not a caching numba dispatcher, or this numba keeps its cache otherwise)."""
    try:
        cache_file = dispatcher._cache._cache_file  # type: ignore[attr-defined]
        index = cache_file._load_index()
    except Exception:  # numba's private cache API changed: unknown, say nothing
        return None
    return bool(index)


def cold_kernels(
    kernels: Sequence[tuple[str, str, float]] = RUN_KERNELS,
) -> list[tuple[str, str, float]] | None:
    """The kernels of ``kernels`` with no current compile in numba's cache (in order);
    None when that cannot be told (see :func:`_is_cached`)."""
    cold = []
    for module, name, seconds in kernels:
        state = _is_cached(getattr(importlib.import_module(module), name))
        if state is None:
            return None
        if not state:
            cold.append((module, name, seconds))
    return cold


#: Seconds the second process of :mod:`coopproc.jit_ahead` takes to start (imports).
AHEAD_START_S = 2.0


def compile_note(
    kernels: Sequence[tuple[str, str, float]] = RUN_KERNELS,
    *,
    cold: Sequence[tuple[str, str, float]] | None = None,
    ahead: Collection[tuple[str, str]] = (),
) -> str | None:
    """The one line a run prints before it compiles its kernels, None when they are all
    cached (or the cache cannot be read). ``cold``: :func:`cold_kernels` if the caller has
    it; ``ahead``: the (module, kernel) a second process compiles meanwhile
    (:mod:`coopproc.jit_ahead`): the longer of the two shares is said."""
    cold = cold_kernels(kernels) if cold is None else cold
    if not cold:
        return None
    here = sum(s for m, k, s in cold if (m, k) not in ahead)
    there = sum(s for m, k, s in cold if (m, k) in ahead)
    seconds = max(here, there + AHEAD_START_S) if there else here
    about = f"about {5 * max(1, round(seconds / 5))} s" if seconds >= 5 else "a few seconds"
    return f"compiling the numerical kernels (once after install, {about})"
