"""Large temporaries reused instead of mapped afresh.

glibc's malloc hands blocks above its mmap threshold (128 kB, raised dynamically up to 32 MB) to fresh
``mmap`` pages and gives them back on ``free``: every large NumPy temporary then costs the kernel a page
fault per 4 kB page on first touch. The frequency-response batches of the design commands are such
temporaries, made and dropped thousands of times, and the faults took a fifth of their CPU time.
``keep_freed_memory`` raises the mmap threshold and the trim threshold (``mallopt``, glibc's documented
tuning interface, ``man 3 mallopt``) so freed blocks stay in the process for the next batch; elsewhere
(not glibc) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util

#: mallopt parameters (malloc.h)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
#: blocks up to this size come from the heap (bytes; glibc's largest allowed value on 64-bit is 32 MB)
MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
#: the heap is given back to the system when this much is free at its top (bytes)
TRIM_THRESHOLD_BYTES = 256 * 1024 * 1024


def keep_freed_memory() -> bool:
    """Set glibc's mmap and trim thresholds for this process; True when they were set."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(M_TRIM_THRESHOLD,
                                                                                 TRIM_THRESHOLD_BYTES))
