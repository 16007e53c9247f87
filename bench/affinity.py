"""CPU placement for the client/server benchmarks.

On a 2-CPU machine a server that shares the client's CPU runs at a fraction of its rate, whichever
server it is; that swamps any comparison. The benchmarks put their servers on one CPU and their
clients on another.
"""

from __future__ import annotations

import os

#: Put at the top of a server child process's code: it moves to the highest CPU.
PIN_SERVER = """
import os
if hasattr(os, "sched_setaffinity") and len(os.sched_getaffinity(0)) > 1:
    os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})
"""


def pin_client() -> set[int] | None:
    """Move this (client) process to the lowest CPU; returns the CPUs to restore, or None."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    cpus = os.sched_getaffinity(0)
    if len(cpus) < 2:
        return None
    os.sched_setaffinity(0, {min(cpus)})
    return cpus


def restore(cpus: set[int] | None) -> None:
    if cpus is not None:
        os.sched_setaffinity(0, cpus)
