"""When this process started, on the `time.perf_counter` clock: the run's `launch` phase
(the interpreter, the imports before PETSc, PETSc's and MPI's start) counts from here."""

from __future__ import annotations

import os
import time

LATEST = 3600.0
"""A start further back than this (seconds) is not this run's launch (e.g. a study)."""


def process_start() -> float | None:
    """perf_counter value of this process's start (from /proc/self/stat, 1 / CLK_TCK
    resolution, 10 ms on Linux), or None when it cannot be read."""
    try:
        with open("/proc/self/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        ticks = int(fields[19])  # field 22 of proc(5), starttime, clock ticks after boot
        ago = time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None
    if not 0.0 <= ago <= LATEST:
        return None
    return time.perf_counter() - ago
