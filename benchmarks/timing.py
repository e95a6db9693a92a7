"""Shared helpers of the benchmark scripts (imported from the scripts' folder): timing, and
the ``lab`` package of a baseline revision to time against."""

import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def best_of(fn, n=7):
    """Smallest wall time in seconds of ``n`` calls of ``fn()`` (least disturbed by other load)."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def baseline_code(rev: str, into: Path) -> Path:
    """The ``lab`` package at git revision ``rev`` (``git archive``), extracted under ``into``;
    put ``into`` on a child process's PYTHONPATH to run the baseline's code."""
    into.mkdir(parents=True, exist_ok=True)
    tar = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "lab"], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=tar, check=True)
    return into
