"""The machine a benchmark runs on, printed beside its figures (figures from another machine do not compare)."""

from __future__ import annotations

import os
import platform
from pathlib import Path


def machine_line() -> str:
    """``machine: <CPU model>, <n> CPUs, load average <1 min> (<system>)``."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = f"{os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else "n/a"
    return f"machine: {model}, {os.cpu_count()} CPUs, load average {load} ({platform.system()})"
