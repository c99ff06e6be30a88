"""The machine a result was measured on: CPU model, core count and library versions.

A seed's episode rows are byte-identical on one machine but not across CPU generations (the
float kernels MuJoCo and torch pick differ in the last bits, and a fall's chaotic contacts grow
that into other outcomes; docs/benchmark.md, *Seeds and determinism*), so evaluation summaries and model cards name it.
"""

from __future__ import annotations

import datetime
import os
import platform
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any


def cpu_model() -> str:
    """The CPU's marketing name (Linux ``/proc/cpuinfo``), else the architecture."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def versions() -> dict[str, str]:
    """Versions of the libraries that decide the numbers (rsl-rl-lib where installed)."""
    import mujoco
    import numpy
    import torch

    out = {"torch": torch.__version__, "mujoco": mujoco.__version__, "numpy": numpy.__version__,
           "python": platform.python_version()}
    try:
        out = {"rsl_rl_lib": version("rsl-rl-lib"), **out}
    except PackageNotFoundError:
        pass
    return out


def machine() -> dict[str, Any]:
    """CPU model, logical cores, library versions and today's date (UTC), for a results file."""
    today = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    return {"cpu": cpu_model(), "cores": os.cpu_count(), "versions": versions(), "date": today}
