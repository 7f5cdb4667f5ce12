"""glibc's malloc tuned for the learners' gradient steps (issue 58).

By default glibc maps each block above its (dynamic) mmap threshold afresh and unmaps it when
freed, and returns free heap above 128 KiB to the system. A gradient step allocates MBs of
activations at batch 64 and frees them again, so every update paid thousands of page faults on
freshly mapped memory: ~4,500, about 12 ms of system time in an 88 ms relmogen-r update.
``keep_freed_memory`` raises both thresholds; the learners (``SharedEncoderSAC.train``,
``RelmogenDQN.train``) call ``keep_freed_memory_once`` before their first update.
``relmogen.bench.train_bench`` (``bench_sac_update_variants``, ``bench_qmap_update_allocator``)
measures it.
"""

from __future__ import annotations

import ctypes
import ctypes.util

# glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
MMAP_THRESHOLD = 32 * 2**20  # glibc's maximum on 64-bit: larger blocks (the replay arrays) stay mmapped
TRIM_THRESHOLD = 256 * 2**20  # free heap kept at the top before glibc returns it to the system
_kept_freed_memory = False  # whether keep_freed_memory_once has run in this process


def keep_freed_memory(mmap_threshold: int = MMAP_THRESHOLD, trim_threshold: int = TRIM_THRESHOLD) -> bool:
    """Have glibc's malloc serve blocks below ``mmap_threshold`` from its heap and keep up to
    ``trim_threshold`` of freed heap: by default it maps the gradient step's large activations
    (MBs at batch 64) afresh and unmaps them when freed, so every update paid ~4,500 page faults,
    about 12 ms of system time in an 88 ms relmogen-r update (issue 58). The values computed are
    untouched; the process holds its peak heap instead of returning it. False (and nothing done)
    without glibc."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    mapped = mallopt(_M_MMAP_THRESHOLD, int(mmap_threshold))
    return bool(mapped) and bool(mallopt(_M_TRIM_THRESHOLD, int(trim_threshold)))


def keep_freed_memory_once() -> None:
    """``keep_freed_memory`` the first time it is called in this process; later calls do nothing
    (a forked child inherits both the thresholds and the flag)."""
    global _kept_freed_memory
    if not _kept_freed_memory:
        keep_freed_memory()
        _kept_freed_memory = True
