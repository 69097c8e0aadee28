"""Large allocations given back to the system when freed (glibc's ``malloc``).

glibc serves allocations above its mmap threshold with their own mappings, returned at
``free``; but after such a block is freed it raises the threshold to that block's size (up
to 32 MB), so later packets of that size come from the heap's arenas, which keep what is
freed. A daemon taking 8.9 MB packets then held tens of MB more than the packets it had
(docs/decisions.md, Ingest memory). A fixed threshold turns that adjustment off.
"""

from __future__ import annotations

import ctypes
import sys

M_MMAP_THRESHOLD = -3  # mallopt's parameter (malloc.h)
MMAP_THRESHOLD = 1 << 20  # bytes: blocks this large get a mapping of their own


def fix_mmap_threshold() -> bool:
    """Fix glibc's mmap threshold at :data:`MMAP_THRESHOLD` for this process; False where
    there is no glibc ``mallopt`` (another libc or system), which leaves malloc as it is."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
