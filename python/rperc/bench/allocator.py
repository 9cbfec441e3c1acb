"""A steady allocator for timing: large buffers recycled, not mapped anew.

glibc's ``malloc`` serves a block above its mmap threshold (128 KiB at start) with a
fresh ``mmap`` and returns it to the kernel on ``free``; the next one is mapped again
and every page of it faulted in and zeroed. The threshold then moves: once a mapped
block is freed it rises to that block's size, up to 32 MiB. So how fast a tracker
that allocates frame-sized arrays runs depends on what the process freed before it.
OpenCV's affine ECC on the pattern bench's 640 x 480 frames (float32 copies and a
pyramid, about 1.2 MiB a frame) ran at 105-125 fps in a fresh interpreter and at
180-320 fps after one 12 MB temporary had been freed, on the same frames
(``rperc bench pattern``'s cases, seed 10, on the development machine). A ratio
between two trackers measured in one process would depend on the order they ran in.

:func:`steady_allocator` fixes both thresholds high for the whole process, so every
method is timed with its buffers recycled, the peers at their best. It changes no
result, only where memory comes from.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: ``mallopt`` parameters (glibc's ``malloc.h``).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3

#: Blocks below this come from the heap and are reused (glibc's dynamic ceiling).
MMAP_THRESHOLD = 32 << 20
#: The heap's free top is returned to the kernel only beyond this.
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD


def steady_allocator() -> bool:
    """Fixes glibc's mmap and trim thresholds (see the module's text) in this process;
    whether it could: ``False`` off Linux or with another C library (musl has no
    ``mallopt``), where nothing changes."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    # mallopt returns 1 on success and 0 on an error.
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    )
