"""A Ctrl-C, SIGTERM or SIGHUP while the command line is still importing its modules stops it
cleanly: one line, exit 128 + the signal, no traceback (it used to die by SIGINT with a
traceback, or leave a half-imported module that failed later with ImportError).

The signal is delivered deterministically: an import hook raises it from inside the import of
a command module, as the real signal would at that moment.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest
from helpers import default_sigint, subprocess_env

HOOK = """
import os, runpy, signal, sys, threading

class Interrupt:
    def find_spec(self, name, path=None, target=None):
        if name == "lab.cli.train":
            os.kill(os.getpid(), {signum})
            signal.pthread_kill(threading.get_ident(), 0)  # let the handler run now
        return None

sys.meta_path.insert(0, Interrupt())
sys.argv = ["lab", "train", "x.csv", "--out", "m.npz"]
runpy.run_module("lab", run_name="__main__")
"""


@pytest.mark.parametrize(
    "signum, code, words",
    [(signal.SIGINT, 130, "(Ctrl-C)"), (signal.SIGTERM, 143, "by SIGTERM"), (signal.SIGHUP, 129, "by SIGHUP")],
)
def test_a_signal_while_importing_stops_cleanly(signum, code, words, tmp_path):
    r = subprocess.run(
        [sys.executable, "-c", HOOK.format(signum=int(signum))],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env=subprocess_env(),
        preexec_fn=default_sigint,
    )
    assert r.returncode == code, r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    assert f"interrupted {words} while starting; nothing was done" in r.stderr
    assert not (tmp_path / "m.npz").exists()
