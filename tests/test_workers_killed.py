"""``kill -9`` of a run with worker processes leaves no process behind.

The run cannot clean up after SIGKILL, so each loky worker watches its parent from the
moment it starts (:func:`lab.workers.worker_config`'s initializer), not only from its first
task: the workers of a run killed while they were still starting used to live on, and with
them the two resource trackers (which live until the last process holding their pipe is
gone). Each command here is killed as soon as its first worker exists -- the hardest case.

Bound: a worker needs to finish starting (importing NumPy and unpickling the initializer,
under a second idle; several on a loaded 2-core machine) and then notices within
:data:`lab.workers.WATCH_INTERVAL_S`; 60 s leaves a wide margin for load.
"""

from __future__ import annotations

import subprocess
import sys
import time

import psutil
import pytest
from helpers import subprocess_env, wait_until
from sweep import ROOT, make_inputs

WORKER_WORDS = ("popen_loky", "resource_tracker")
COMMANDS = {
    "train-ensemble": ["train", "{dir}/data.csv", "--model", "ensemble", "--members", "4", "--jobs", "2"],
    "splits": ["splits", "{dir}/data.csv", "--n-splits", "8", "--jobs", "2"],
    "transfer-calibrated": [
        "transfer", "--method", "calibrated", "--robot", "three-cable",
        "--sim", "{dir}/data.csv", "--real", "{dir}/data.csv",
        "--n-rings", "1", "--n-axial", "4", "--jobs", "2",
    ],
    "transfer-curve": [
        "transfer-curve", "--sim-model", str(ROOT / "data" / "model_sim_three_cable.npz"), "--family", "2",
        "--ns", "0", "4", "--n-test", "4", "--n-points", "4", "--methods", "sim-only", "residual",
        "--n-rings", "1", "--n-axial", "6", "--jobs", "2",
    ],
}  # fmt: skip


def _helpers_of(proc: psutil.Process) -> list[psutil.Process]:
    out = []
    for p in proc.children(recursive=True):
        try:
            if any(w in " ".join(p.cmdline()) for w in WORKER_WORDS):
                out.append(p)
        except psutil.NoSuchProcess:
            pass
    return out


def _alive(p: psutil.Process) -> bool:
    try:
        return p.is_running() and p.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.timeout(240)
@pytest.mark.parametrize("name", COMMANDS)
def test_kill_9_while_workers_start_leaves_no_process(name, tmp_path):
    make_inputs(tmp_path)
    ext = "csv" if name in ("splits", "transfer-curve") else "npz"
    argv = [a.replace("{dir}", str(tmp_path)) for a in COMMANDS[name]] + ["--out", str(tmp_path / f"o.{ext}")]
    proc = subprocess.Popen(
        [sys.executable, "-m", "lab", *argv],
        cwd=tmp_path,
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    helpers = []
    try:
        parent = psutil.Process(proc.pid)

        def started():
            helpers[:] = _helpers_of(parent)
            return any("popen_loky" in " ".join(p.cmdline()) for p in helpers if _alive(p))

        wait_until(lambda: started() or proc.poll() is not None, 120, "the first worker")
        assert proc.poll() is None, f"{name} ended before starting a worker: {proc.stderr.read()[-2000:]}"
        proc.kill()
        proc.wait()
        t0 = time.monotonic()
        wait_until(lambda: not any(_alive(p) for p in helpers), 60, f"the workers and trackers of {name} to exit")
        assert time.monotonic() - t0 < 60
    finally:
        if proc.poll() is None:
            proc.kill()
        for p in helpers:
            if _alive(p):
                p.kill()
