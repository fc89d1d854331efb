"""Memory the process no longer uses, given back to the system (issue 11).

glibc's allocator keeps most freed C-heap pages (CSV parser buffers, numpy arrays of a
finished stage) for later use, so a long run would go on holding hundreds of MB it has
freed; the readers, the checks and the run's step loop call
:func:`release_freed_memory` where large intermediates were just let go.
"""

from __future__ import annotations

import ctypes
import functools
import sys
from collections.abc import Callable

__all__ = ["release_freed_memory"]


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None).malloc_trim  # type: ignore[no-any-return]
    except (OSError, AttributeError):  # not glibc (musl has none)
        return None


def release_freed_memory() -> None:
    """Give the C heap's free pages back to the system (glibc ``malloc_trim``).

    The CSV parsers' buffers are freed after a read, but the allocator keeps most of
    them (several hundred MB after a day of logs), so the process would go on holding
    them; a no-op where there is no ``malloc_trim``."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)
