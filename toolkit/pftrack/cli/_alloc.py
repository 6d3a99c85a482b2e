"""Large arrays kept in the process's heap (glibc only), set once by the ``pftrack`` command.

glibc serves every allocation above its mmap threshold (32 MB at most, by default) with fresh
pages from the kernel and hands them back on ``free``. The engine allocates its large arrays
anew every frame (at a million particles: the (N, 6) states twice, the (N, 4) boxes, several
(N,) weights: about 170 MB), so each frame pays the kernel for zeroing them on first touch:
about 10 ms of a 60 ms step. With the mmap and trim thresholds raised to
:data:`HEAP_ARRAYS_UP_TO` the freed arrays stay in the heap and the next frame reuses them.

Nothing computed changes. The cost: memory a run frees is kept by the process (up to the
run's peak) instead of going back to the system at once. ``PFTRACK_MALLOC=default`` keeps
glibc's defaults. Only the command-line entry point calls :func:`keep_large_arrays`; importing
:mod:`pftrack` changes nothing.
"""

from __future__ import annotations

import ctypes
import os
import sys

__all__ = ["HEAP_ARRAYS_UP_TO", "keep_large_arrays", "kept"]

#: Arrays up to this many bytes come from (and return to) the heap: 256 MB, above the (1M, 6)
#: float64 states (48 MB) with room for the largest per-frame arrays of the benchmarks.
HEAP_ARRAYS_UP_TO = 256 * 1024 * 1024

_M_TRIM_THRESHOLD = -1  # glibc's mallopt parameters (malloc.h)
_M_MMAP_THRESHOLD = -3

_kept = False


def kept() -> bool:
    """Whether :func:`keep_large_arrays` has raised the thresholds in this process."""
    return _kept


def keep_large_arrays() -> bool:
    """Raise glibc's mmap and trim thresholds to :data:`HEAP_ARRAYS_UP_TO` (once); False and
    nothing changed when ``PFTRACK_MALLOC=default``, off Linux, or without glibc."""
    global _kept
    if _kept:
        return True
    if os.environ.get("PFTRACK_MALLOC", "").strip().lower() == "default":
        return False
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version  # noqa: B018 - glibc only (musl has mallopt as a stub)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    # the trim threshold first: with it, freed top-of-heap arrays are not returned at once
    _kept = (mallopt(_M_TRIM_THRESHOLD, HEAP_ARRAYS_UP_TO) == 1
             and mallopt(_M_MMAP_THRESHOLD, HEAP_ARRAYS_UP_TO) == 1)
    return _kept
