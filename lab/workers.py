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

__all__ = ["WATCH_INTERVAL_S", "watch_parent", "worker_config", "kill_local_workers", "default_jobs"]

#: How often a worker checks that its parent is alive, seconds.
WATCH_INTERVAL_S = 0.5
_watched_parent: int | None = None


def watch_parent(interval_s: float = WATCH_INTERVAL_S, parent_pid: int | None = None) -> None:
    """In a worker process: start (once) a daemon thread that ends the process when its
    parent dies. Does nothing in a main process, which may rightly outlive its shell.

    ``parent_pid``: the run's process id, when the caller knows it (the workers' initializer
    passes it, so a run killed while its workers were still starting is noticed too); default
    the parent now. The worker also ignores SIGINT from then on: Ctrl-C reaches the whole
    process group, and the run stops its workers itself.

    Parameters
    ----------
    interval_s : float
        How often the thread checks the parent (s).
    parent_pid : int, optional
        The run's process id; default the parent now.
    """
    global _watched_parent
    if _watched_parent is not None or multiprocessing.current_process().name == "MainProcess":
        return
    _watched_parent = os.getppid() if parent_pid is None else parent_pid
    if threading.current_thread() is threading.main_thread():  # signal handlers live there only
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while True:
            if os.getppid() != _watched_parent:  # re-parented: the run that started us is gone
                os._exit(1)
            threading.Event().wait(interval_s)

    threading.Thread(target=watch, name="lab-watch-parent", daemon=True).start()


def _watch_run(parent_pid: int) -> None:
    """The workers' initializer (runs in each worker as it starts)."""
    watch_parent(parent_pid=parent_pid)


def _spawn_with_sigint_blocked(fork_exec):
    """loky's ``fork_exec`` run with SIGINT blocked in the spawning thread: the new worker
    inherits the blocked mask across fork and exec (as loky's resource tracker does it), so
    a Ctrl-C while it imports its modules stays pending instead of printing a traceback."""

    def spawn(*args, **kwargs):
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            return fork_exec(*args, **kwargs)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)  # a Ctrl-C meanwhile is delivered here

    spawn.lab_blocks_sigint = True
    return spawn


def _workers_start_with_sigint_blocked() -> None:
    """Make every loky worker start with SIGINT blocked (once per process; POSIX only)."""
    if not hasattr(signal, "pthread_sigmask"):
        return
    from joblib.externals.loky.backend import fork_exec as module  # looked up at each spawn (joblib 1.6)

    if not getattr(module.fork_exec, "lab_blocks_sigint", False):
        module.fork_exec = _spawn_with_sigint_blocked(module.fork_exec)


def worker_config():
    """``joblib.parallel_config`` for lab's worker processes: loky, one thread each, and every
    worker watching this process from the moment it starts (not only from its first task), so
    a run killed (``kill -9``) while its workers are still starting leaves no worker -- and so
    no resource tracker, which lives until the last worker holding its pipe is gone -- behind.
    Workers start with SIGINT blocked: Ctrl-C reaches the whole process group, the run stops
    its workers itself, and a worker still importing would only print a traceback.

    Returns
    -------
    joblib.parallel_config
        The context manager to run ``joblib.Parallel`` in.
    """
    from joblib import parallel_config
    from joblib.parallel import LokyBackend

    _workers_start_with_sigint_blocked()
    backend = LokyBackend(initializer=_watch_run, initargs=(os.getpid(),))
    return parallel_config(backend=backend, inner_max_num_threads=1)


def kill_local_workers(wait: bool = True) -> None:
    """Kill the worker processes of joblib's (reusable) loky executor, if there is one.

    With ``wait`` (the default) it also waits until the executor has shut down, about a
    second at most: a process that leaves before then makes loky's resource tracker warn
    about leaked semaphores.

    Parameters
    ----------
    wait : bool
        Wait until the executor has shut down.
    """
    from joblib.externals.loky import reusable_executor

    executor = getattr(reusable_executor, "_executor", None)  # loky's singleton (joblib 1.6)
    if executor is not None:
        executor.shutdown(wait=False, kill_workers=True)  # kill first: nothing waits on a busy worker
        if wait:
            executor.shutdown(wait=True, kill_workers=True)


def default_jobs() -> int:
    """Worker processes to use by default.

    Returns
    -------
    int
        The cores this process may run on (at least 1).
    """
    return max(1, len(os.sched_getaffinity(0))) if hasattr(os, "sched_getaffinity") else max(1, os.cpu_count() or 1)
