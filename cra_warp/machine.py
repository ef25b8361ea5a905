"""The machine a figure was measured on: every benchmark and campaign records it (the CPU changes between
sessions, and native bf16 exists only on some)."""

from __future__ import annotations

import os
from pathlib import Path


def cpu_info() -> dict:
    """lscpu's model name and the flags that decide the update's precision (every figure records them)."""
    import platform

    model, flags = platform.processor(), []
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and model in ("", "x86_64"):
                model = line.split(":", 1)[1].strip()
            elif line.startswith("flags"):
                flags = line.split(":", 1)[1].split()
                break
    except OSError:
        pass
    keep = ("avx2", "avx512f", "avx512_bf16", "amx_bf16", "amx_tile", "fma")
    info = {"model": model, "flags": [f for f in keep if f in flags], "cores": os.cpu_count()}
    # the instruction set torch's kernels and oneDNN actually use: ATEN_CPU_CAPABILITY / ONEDNN_MAX_CPU_ISA can hold
    # them below the CPU's (an AVX2-only machine measured on an AVX-512 one)
    import torch

    info["torch_isa"] = torch.backends.cpu.get_cpu_capability()
    if os.environ.get("ONEDNN_MAX_CPU_ISA"):
        info["onednn_max_isa"] = os.environ["ONEDNN_MAX_CPU_ISA"]
    return info
