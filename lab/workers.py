"""Worker processes that never outlive their run.

Simulation walks (:mod:`lab.data.simulation`) and training studies (:mod:`lab.learn.studies`)
run on joblib's loky worker processes. A run stopped by Ctrl-C or SIGTERM kills its
workers (:func:`kill_local_workers`); a run killed with ``kill -9`` cannot, so each
worker watches its parent (:func:`watch_parent`, called at the start of every task) and
exits within about :data:`WATCH_INTERVAL_S` once the parent is gone, instead of computing
chunks nobody will collect for minutes.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading

__all__ = ["WATCH_INTERVAL_S", "watch_parent", "kill_local_workers", "default_jobs"]

#: How often a worker checks that its parent is alive, seconds.
WATCH_INTERVAL_S = 0.5
_watched_parent: int | None = None


def watch_parent(interval_s: float = WATCH_INTERVAL_S) -> None:
    """In a worker process: start (once) a daemon thread that ends the process when its
    parent dies. Does nothing in a main process, which may rightly outlive its shell.

    The worker also ignores SIGINT from then on: Ctrl-C reaches the whole process group,
    and the run (main process) stops its workers itself; a worker would only print a
    traceback for every task it was running."""
    global _watched_parent
    if _watched_parent is not None or multiprocessing.current_process().name == "MainProcess":
        return
    _watched_parent = os.getppid()
    if threading.current_thread() is threading.main_thread():  # signal handlers live there only
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while True:
            threading.Event().wait(interval_s)
            if os.getppid() != _watched_parent:  # re-parented: the run that started us is gone
                os._exit(1)

    threading.Thread(target=watch, name="lab-watch-parent", daemon=True).start()


def kill_local_workers(wait: bool = True) -> None:
    """Kill the worker processes of joblib's (reusable) loky executor, if there is one.

    With ``wait`` (the default) it also waits until the executor has shut down, about a
    second at most: a process that leaves before then makes loky's resource tracker warn
    about leaked semaphores."""
    from joblib.externals.loky import reusable_executor

    executor = getattr(reusable_executor, "_executor", None)  # loky's singleton (joblib 1.6)
    if executor is not None:
        executor.shutdown(wait=False, kill_workers=True)  # kill first: nothing waits on a busy worker
        if wait:
            executor.shutdown(wait=True, kill_workers=True)


def default_jobs() -> int:
    """Worker processes to use by default: the cores this process may run on."""
    return max(1, len(os.sched_getaffinity(0))) if hasattr(os, "sched_getaffinity") else max(1, os.cpu_count() or 1)
