"""Keep freed memory for reuse instead of handing it back to the OS at once (glibc).

A sonar ping allocates and frees arrays of 0.1–2 MB (ray batches, images). With glibc's
default, dynamically adjusted thresholds, such blocks are often returned to the OS on
``free`` (``munmap``, or a trim of the heap top) and faulted in again on the next ping:
up to ~2000 page faults and a third of a ping's time on the pier benchmark, depending on
what the process allocated before. Pinning the thresholds serves those blocks from the
heap and keeps freed heap memory for the next ping (steady-state memory is unchanged: the
same blocks are reused; see ``uhrisim bench sonar``'s 10 000-ping memory check).

This changes process-wide allocator settings, so the library never does it on import:
the ``uhrisim`` command line calls :func:`keep_freed_memory` at start (a side effect at
the edge); a program embedding the simulator may call it too. A no-op where the C library
is not glibc.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

log = logging.getLogger(__name__)

# mallopt parameter numbers (glibc <malloc.h>).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3

#: Blocks below this are served from the heap (glibc caps the setting at 32 MiB on 64-bit).
MMAP_THRESHOLD_BYTES = 32 * 2**20
#: Free memory at the top of the heap is handed back to the OS only beyond this.
TRIM_THRESHOLD_BYTES = 256 * 2**20


def keep_freed_memory() -> bool:
    """Pin glibc's mmap and trim thresholds (see the module docstring). Returns True when
    the settings were applied, False when this C library has no ``mallopt``."""
    libc_name = ctypes.util.find_library("c")
    try:
        mallopt = ctypes.CDLL(libc_name).mallopt
    except (OSError, AttributeError, TypeError):
        log.debug("no glibc mallopt here (%s): allocator left as it is", libc_name)
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    applied = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )
    if not applied:
        log.debug("mallopt refused the thresholds: allocator left as it is")
    return applied
