"""The cores a run may use: the CPUs this process may run on (its affinity mask, which
``taskset`` or a cpuset narrows; a CPU quota does not), else the machine's count; and how
many of them other processes keep busy now."""

from __future__ import annotations

import os


def usable_cores() -> int:
    """CPUs this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def free_cores(loadavg: str = "/proc/loadavg") -> int | None:
    """Cores free beside this process now: those it may run on, less its own and those the
    runnable tasks of other processes keep busy (may be negative); None where the counts
    cannot be read (:func:`others_runnable`)."""
    others = others_runnable(loadavg)
    return None if others is None else usable_cores() - 1 - others


def others_runnable(loadavg: str = "/proc/loadavg", readings: int = 3) -> int | None:
    """Tasks of other processes runnable now (the least of ``readings`` a millisecond
    apart); None where the counts cannot be read."""
    import time

    counts = []
    for k in range(readings):
        if k:
            time.sleep(0.001)
        try:
            with open(loadavg, encoding="ascii") as stream:
                runnable = int(stream.read().split()[3].split("/")[0])
        except (OSError, ValueError, IndexError):
            return None
        counts.append(max(runnable - _own_running_threads(), 0))
    return min(counts)


def _own_running_threads() -> int:
    """This process's threads that are running or runnable (state R; at least the caller)."""
    running = 0
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return 1
    for task in tasks:
        try:
            with open(f"/proc/self/task/{task}/stat", encoding="ascii", errors="replace") as stream:
                running += stream.read().rsplit(")", 1)[1].split()[0] == "R"
        except (OSError, IndexError):
            continue
    return max(running, 1)
