"""Fault-sweep rows (tests/sweep.py format) for the transfer curve's output file and the
calibrated transfer's real samples.

``transfer-curve`` rewrites its whole results file after each robot, so two runs on one
``--out`` would each drop the other's rows: a run holds ``OUT.lock`` and a second is refused
at once, before it writes anything; a user's file named ``OUT.lock`` is not taken (nor
deleted). ``transfer --method calibrated`` refuses tips farther from the nominal FEM's than
any body of the robot's size reaches (positions in cm or mm read as metres), naming the
file, the column and the unit they would fit, before the fit and the re-simulation.
"""

from pathlib import Path

from filelock import FileLock
from sweep import Case

CURVE = ["transfer-curve", "--sim-model", "{dir}/model.npz", "--family", "1", "--ns", "6"]
CALIBRATED = ["transfer", "--method", "calibrated", "--robot", "three-cable", "--sim", "{dir}/data.csv"]

_held: dict[str, FileLock] = {}


def _hold_lock(name: str):
    """A setup that holds ``name``.lock as another run would (released by :func:`_release`)."""

    def setup(d: Path):
        lock = FileLock(str(d / name) + ".lock", timeout=0)
        lock.acquire()
        _held[str(d)] = lock

    return setup


def _release(d: Path) -> None:
    lock = _held.pop(str(d), None)
    if lock is not None:
        lock.release()


def _scaled_tips(name: str, scale: float, n: int = 12):
    """A setup writing ``name``: the first ``n`` samples of data.csv, tips times ``scale``."""

    def setup(d: Path):
        from lab.data import read_dataset, write_dataset

        u, y, meta = read_dataset(d / "data.csv")
        write_dataset(d / name, u[:n], scale * y[:n], {"robot": meta.get("robot")})

    return setup


DESIGNS_CASES = [
    Case(
        "transfer-curve-output-locked",
        [*CURVE, "--out", "{dir}/tc.csv"],
        2,
        ("--out {dir}/tc.csv is being written by another run", "wait for it"),
        setup=_hold_lock("tc.csv"),
        absent=("{dir}/tc.csv", "{dir}/tc.csv.json"),
        after=_release,
    ),
    Case(
        "transfer-curve-lock-file-is-sim-model",
        ["transfer-curve", "--sim-model", "{dir}/tc.csv.lock", "--family", "1", "--out", "{dir}/tc.csv"],
        2,
        ("--out lock", "is the input --sim-model"),
        ("{dir}/tc.csv.lock",),
        setup=lambda d: (d / "tc.csv.lock").write_bytes((d / "model.npz").read_bytes()),
        absent=("{dir}/tc.csv", "{dir}/tc.csv.json"),
    ),
    *(
        Case(
            f"transfer-calibrated-tips-in-{unit}",
            [*CALIBRATED, "--real", f"{{dir}}/{unit}.csv", "--out", "{dir}/m.npz"],
            2,
            (
                f"--real {{dir}}/{unit}.csv: column 'x'",
                "from where the nominal FEM of three-cable puts it",
                f"read as {unit}",
            ),
            (f"{{dir}}/{unit}.csv",),
            setup=_scaled_tips(f"{unit}.csv", scale),
            absent=("{dir}/m.npz",),
        )
        for unit, scale in (("cm", 100.0), ("mm", 1000.0))
    ),
]
