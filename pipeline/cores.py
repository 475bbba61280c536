"""The cores a run may use: the CPUs this process may run on (its affinity mask, which a
container or ``taskset`` narrows), else the machine's count."""

from __future__ import annotations

import os


def usable_cores() -> int:
    """CPUs this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1
