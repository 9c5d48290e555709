"""The machine a benchmark ran on, printed beside its numbers: the same code measured on an
AVX-512 host and on an AVX2-only one differs by a third and more in the block path (eight
float64 per vector register against four), and this project's reference machine has been
either from one day to the next."""

from __future__ import annotations

import os
import platform


def describe() -> str:
    """One line: the CPU's model name, LLVM's name for its microarchitecture (what numba
    compiles for), its widest vector extension and the CPU count."""
    import llvmlite.binding as llvm

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            model = next(
                (line.split(":", 1)[1].strip() for line in f if line.startswith("model name")),
                model,
            )
    except OSError:  # not Linux
        pass
    features = llvm.get_host_cpu_features()
    if features.get("avx512f"):
        vector = "AVX-512"
    elif features.get("avx2"):
        vector = "AVX2, no AVX-512"
    else:
        vector = "no AVX2"
    return f"host: {model} (LLVM {llvm.get_host_cpu_name()}; {vector}), {os.cpu_count()} CPUs"
