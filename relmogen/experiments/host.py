"""What machine a benchmark ran on: every ``relmogen bench`` JSON carries ``host_info()``.

CPU-hour figures differ by host kind, not only by code: a relmogen-d update costs 2.5-3x more on
an AMD EPYC with AVX2 than on an Intel Xeon with AVX-512 and AMX (docs/benchmarks.md), so a
figure without its host cannot be compared with another.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

# x86 instruction-set extensions that decide the convolution kernels oneDNN picks (Linux flag names)
ISA_FLAGS = ("avx2", "avx512f", "avx512_bf16", "amx_tile", "amx_bf16")


def cpu_model_and_flags(cpuinfo: str) -> tuple[str, set[str]]:
    """The first processor's ``model name`` and ``flags`` from the text of /proc/cpuinfo."""
    model, flags = "", set()
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        if key == "model name" and not model:
            model = value.strip()
        elif key == "flags" and not flags:
            flags = set(value.split())
    return model, flags


def host_kind(flags: set[str]) -> str:
    """The name used beside CPU-hour figures: ``avx512-amx``, ``avx512``, ``avx2`` or ``other``."""
    if "avx512f" in flags:
        return "avx512-amx" if "amx_tile" in flags else "avx512"
    return "avx2" if "avx2" in flags else "other"


def host_info() -> dict:
    """CPU model, its instruction sets, core count and the torch build and thread count."""
    import torch

    cpuinfo = Path("/proc/cpuinfo")
    model, flags = cpu_model_and_flags(cpuinfo.read_text() if cpuinfo.is_file() else "")
    return {
        "cpu_model": model or platform.processor() or platform.machine(),
        "host_kind": host_kind(flags),
        "isa": {flag: flag in flags for flag in ISA_FLAGS},
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "torch_threads": torch.get_num_threads(),
        "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
    }
