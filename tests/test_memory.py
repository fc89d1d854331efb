"""The memory scopes and the session handover of memory.py (issue 34 part 5)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from coopproc.memory import Held, _malloc_trim

#: A function that frees every other one of 100 arrays of 2 MB after a 20 MB one was
#: freed (glibc then serves 2 MB blocks from the heap and keeps the holes), plain or
#: marked @gives_back; prints the MB given back to the system when it returned.
_FREED = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from coopproc.memory import gives_back

    def rss():
        return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def work():
        big = np.ones(20_000_000 // 8)
        del big
        arrays = [np.ones(2_000_000 // 8) for _ in range(100)]
        return arrays[1::2]

    scope = gives_back(work) if sys.argv[1] == "scope" else work
    before = rss()
    kept = scope()
    print((before + 200e6 - rss()) / 1e6)  # 200 MB made, 100 MB kept
    """
)


def _given_back_mb(kind: str) -> float:
    out = subprocess.run(
        [sys.executable, "-c", _FREED, kind], capture_output=True, text=True, check=True
    )
    return float(out.stdout)


@pytest.mark.skipif(_malloc_trim() is None, reason="needs glibc's malloc_trim")
def test_a_scope_gives_its_freed_arrays_back_when_it_returns() -> None:
    # 50 of the 100 arrays of 2 MB freed inside: 100 MB back with the scope, none without
    assert _given_back_mb("scope") > 90.0
    assert _given_back_mb("plain") < 10.0


def test_a_held_value_is_replaced_for_the_caller() -> None:
    held = Held([1, 2, 3])
    held.replace([1])
    assert held.value == [1] and repr(held) == "Held(list)"
