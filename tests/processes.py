"""Watching a `pendfmu fit` started as a process of its own: its worker processes, their CPU
time, and the moment its global search is running on them (Linux /proc). Shared by the tests
that send signals to a fit or kill its workers at a known point, rather than after a fixed
sleep, which a loaded machine or a first, uncompiled start outlasts."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pytest

WAIT = 150  # seconds a disturbed fit may take before it is taken for hung (the code before issue 28 hung)


def children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []



def cpu_seconds(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def busy_workers(process: subprocess.Popen, cpu: float = 0.1) -> list[int]:
    """The global search's two worker processes (the fit's first) once each has computed for
    `cpu` s; fails if the fit ends first."""
    deadline = time.monotonic() + WAIT
    first = None
    while time.monotonic() < deadline and process.poll() is None:
        workers = children(process.pid)
        first = first or (workers if len(workers) == 2 else None)
        if first and all(cpu_seconds(w) >= cpu for w in first):
            assert children(process.pid) == first, "the search ended before its workers were seen busy"
            return first
        time.sleep(0.01)
    pytest.fail(f"the fit ended (or took {WAIT} s) before its workers ran: {process.communicate()}")
