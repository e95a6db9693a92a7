"""The fault sweep's table format and runner, shared by the ``tests/test_sweep_*.py`` files.

Each row (:class:`Case`) is one bad input, fault or interruption: the command line
(words after ``python -m lab``), the exit code it must end with, words its message must
contain, and the files that must be byte-for-byte unchanged afterwards (the user's
inputs). Every case also checks that no Python traceback is printed and that no
temporary file (``.*.tmp*``) is left behind.

Placeholders in ``argv`` / ``unchanged`` / ``absent``: ``{dir}`` is the case's working
directory (a fresh temporary directory); the files below are made there by
:func:`make_inputs` before each case:

* ``data.csv`` (+ ``data.csv.json``): 60 samples of the shipped FEM dataset;
* ``model.npz``: the shipped three-cable model; ``robot.toml``: the three-cable robot;
* ``traj.csv``: a 4-point circle (``x,y,z``, metres); ``defects.toml``: the shipped defects.
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from helpers import subprocess_env

from lab.control import circle
from lab.control.trajectories import write_trajectory_csv
from lab.data import read_dataset, write_dataset

ROOT = Path(__file__).resolve().parent.parent
#: A coarse mesh, for speed.
COARSE = ["--n-rings", "1", "--n-axial", "6"]


@dataclass
class Case:
    id: str
    argv: list[str]
    code: int
    words: tuple[str, ...] = ()
    unchanged: tuple[str, ...] = ()
    absent: tuple[str, ...] = ()  # files that must not exist afterwards
    setup: Callable[[Path], None] | None = None  # makes more input files in the case's directory
    subprocess: bool = False  # run `python -m lab` in a subprocess (else lab.cli.main in-process)
    limit_file_kib: int | None = None  # subprocess only: `ulimit -f`, to fill the "disk"
    timeout_s: float = 120.0
    after: Callable[[Path], None] | None = None  # extra checks on the directory afterwards
    marks: tuple = field(default_factory=tuple)
    module: str = "lab"  # the program: `python -m lab` or `python -m lab.course` (the scripts' housekeeping)

    def __str__(self) -> str:
        return self.id


def make_inputs(d: Path) -> None:
    u, y, meta = read_dataset(ROOT / "data" / "sim_three_cable.csv")
    write_dataset(d / "data.csv", u[::5][:60], y[::5][:60], {"robot": meta.get("robot"), "note": "sweep subset"})
    shutil.copy(ROOT / "data" / "model_sim_three_cable.npz", d / "model.npz")
    shutil.copy(ROOT / "lab" / "robots" / "three-cable.toml", d / "robot.toml")
    shutil.copy(ROOT / "lab" / "rig" / "defects" / "three-cable.toml", d / "defects.toml")
    write_trajectory_csv(d / "traj.csv", circle(4))


def _fill(text: str, d: Path) -> str:
    return text.replace("{dir}", str(d))


def _digest(path: Path) -> str | None:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None


def run_case(case: Case, d: Path, capsys=None, monkeypatch=None) -> str:
    """Run ``case`` in directory ``d``; assert everything the row says. Returns stderr."""
    make_inputs(d)
    if case.setup:
        case.setup(d)
    argv = [_fill(a, d) for a in case.argv]
    before = {p: _digest(Path(_fill(p, d))) for p in case.unchanged}
    if case.subprocess or case.limit_file_kib:
        env = subprocess_env()
        pre = None
        if case.limit_file_kib:
            import resource

            def pre():
                resource.setrlimit(resource.RLIMIT_FSIZE, (case.limit_file_kib * 1024,) * 2)

        r = subprocess.run(
            [sys.executable, "-m", case.module, *argv],
            cwd=d,
            env=env,
            capture_output=True,
            text=True,
            timeout=case.timeout_s,
            preexec_fn=pre,
        )
        code, err = r.returncode, r.stderr
    else:
        if case.module == "lab.course":
            from lab.course.commands import main
        else:
            from lab.cli import main

        monkeypatch.chdir(d)
        code = main(argv)
        err = capsys.readouterr().err
    assert code == case.code, f"{case.id}: exit code {code}, expected {case.code}; stderr:\n{err}"
    assert "Traceback" not in err, f"{case.id}: traceback shown:\n{err}"
    for w in case.words:
        assert _fill(w, d) in err, f"{case.id}: {w!r} not in the message:\n{err}"
    for p, digest in before.items():
        assert _digest(Path(_fill(p, d))) == digest, f"{case.id}: {p} changed (or vanished)"
    for p in case.absent:
        assert not Path(_fill(p, d)).exists(), f"{case.id}: {p} exists"
    leftovers = [str(p) for p in d.rglob(".*.tmp*")]
    assert not leftovers, f"{case.id}: temporary files left: {leftovers}"
    if case.after:
        case.after(d)
    return err


def numbers(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", skiprows=1)
