"""Shared helpers of the benchmark scripts (imported from the scripts' folder): timing, a
command run beside CPU-bound load, and the ``lab`` package of a baseline revision to time against."""

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


class Printout:
    """A benchmark's printout: each line printed as it comes and kept, written to a file at
    the end (the scripts' ``--out``)."""

    def __init__(self):
        self.lines: list[str] = []

    def say(self, text: str = "") -> None:
        print(text, flush=True)
        self.lines.append(text)

    def write(self, path) -> None:
        Path(path).write_text("\n".join(self.lines) + "\n")


#: What each CPU-bound process of a loaded run executes.
HOG = "while True: pass"


def run_beside_load(cmd: list, load: int, **kwargs):
    """``subprocess.run(cmd, capture_output=True, text=True, **kwargs)`` with ``load`` CPU-bound
    processes (:data:`HOG`) running beside it for the whole run, stopped after it (also on an
    error): ``(result, wall s, the 1/5/15-minute load averages at its end)``; ``result.cpu_s``
    is the CPU time (user + system) of ``cmd`` and every descendant it waited for."""
    hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(load)]
    try:
        t0, cpu0 = time.monotonic(), _children_cpu_s()
        r = subprocess.run(cmd, capture_output=True, text=True, **kwargs)
        r.cpu_s = _children_cpu_s() - cpu0  # (the hogs are waited for only below)
        return r, time.monotonic() - t0, os.getloadavg()
    finally:
        for h in hogs:
            h.kill()
            h.wait()


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


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
