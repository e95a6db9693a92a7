"""The command line's cold start before and after the compiled kernels: section 6 of
benchmarks/bench_assembly.py (imported from the scripts' folder).

Fresh ``python -m lab`` processes, the code before (``git archive REV lab``) and after (this
tree) alternating, each run's child CPU time (user + system, from ``getrusage``; wall time on
a loaded machine says little); numba's cache in a folder of its own (``NUMBA_CACHE_DIR``),
warmed by one run first, and, for the very first call, empty each time.
"""

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from timing import baseline_code

ROOT = Path(__file__).resolve().parent.parent
RUNS = 5
SIMULATE = ["simulate", "--grid", "2", "--jobs", "1", "--no-progress", "--out", "{out}"]
CASES = {
    "python -m lab --help": ["--help"],
    "simulate --grid 2 --jobs 1, default mesh (3,240 tets: compiled)": SIMULATE,
    "the same, --n-rings 1 --n-axial 6 (108 tets: NumPy)": SIMULATE + ["--n-rings", "1", "--n-axial", "6"],
}


#: In a fresh process: CPU s of ``import numba``, and of the first compiled assembly of the
#: default three-cable arm less a second one (loading the kernels from the cache).
LOAD = """import time, numpy as np
t0 = time.process_time()
import numba
t1 = time.process_time()
from lab.description import load_robot
from lab.fem import ArmFEM
f = ArmFEM(load_robot("three-cable"))
q, u = f.rest_q(), np.zeros(3)
t2 = time.process_time()
f.hessian(q, u)
t3 = time.process_time()
f.hessian(q, u)
t4 = time.process_time()
print(t1 - t0, (t3 - t2) - (t4 - t3))
"""


def run(tree: Path, argv: list, env: dict, cwd: Path) -> tuple[float, float]:
    """(child CPU s, wall s) of ``python -m lab *argv`` importing lab from ``tree``."""
    out = cwd / f"out-{time.perf_counter_ns()}.csv"
    argv = [a.replace("{out}", str(out)) for a in argv]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "lab", *argv],
        cwd=cwd,
        env=env | {"PYTHONPATH": str(tree)},
        check=True,
        capture_output=True,
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall


def cold_start(rev: str, say) -> None:
    """Print the table of section 6 through ``say``, the baseline being git revision ``rev``."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        base = baseline_code(rev, tmp / "base")
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env |= {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_CACHE_DIR": str(tmp / "numba-cache")}
        for tree in (base, ROOT):  # each run imports the tree it is meant to
            probe = subprocess.run(
                [sys.executable, "-c", "import lab; print(lab.__file__)"],
                cwd=tmp,
                env=env | {"PYTHONPATH": str(tree)},
                capture_output=True,
                text=True,
                check=True,
            )
            assert probe.stdout.strip().startswith(str(tree)), probe.stdout
        run(ROOT, SIMULATE, env, tmp)  # warm numba's cache
        times = {(case, t): [] for case in CASES for t in ("before", "after")}
        for r in range(RUNS):
            for label, tree in (("before", base), ("after", ROOT))[:: 1 if r % 2 == 0 else -1]:
                for case, argv in CASES.items():
                    times[case, label].append(run(tree, argv, env, tmp))
        load = []
        for _ in range(RUNS):
            out = subprocess.run(
                [sys.executable, "-c", LOAD],
                cwd=tmp,
                env=env | {"PYTHONPATH": str(ROOT)},
                capture_output=True,
                text=True,
                check=True,
            )
            load.append([float(v) for v in out.stdout.split()])
        empty = []
        for r in range(2):
            empty.append(run(ROOT, SIMULATE, env | {"NUMBA_CACHE_DIR": str(tmp / f"empty-{r}")}, tmp))
    say(f"## 6. Cold start of the command line (fresh processes, {RUNS} each; before: {rev})")
    say()
    say("| command | before: CPU s, median (min) | after: CPU s, median (min) | CPU after - before, median (min) |")
    say("|---|---|---|---|")
    for case in CASES:
        b, a = (np.array(times[case, t])[:, 0] for t in ("before", "after"))
        say(
            f"| {case} | {np.median(b):.2f} ({b.min():.2f}) | {np.median(a):.2f} ({a.min():.2f}) | "
            f"{np.median(a) - np.median(b):+.2f} ({a.min() - b.min():+.2f}) |"
        )
    e = np.array(empty)[:, 0]
    warm = np.array(times[list(CASES)[1], "after"])[:, 0]
    say(
        f"| the default-mesh simulate, numba's cache empty (the first call ever compiles the neo-Hookean "
        f"kernels; 2 runs) | | {np.median(e):.2f} ({e.min():.2f}) | {np.median(e) - np.median(warm):+.2f} "
        f"({e.min() - warm.min():+.2f}) against the warm cache |"
    )
    load = np.median(np.array(load), axis=0)
    say()
    say(
        f"Loading the kernels in a fresh process, cache warm (median of {RUNS}): import numba {load[0]:.2f} s CPU, "
        f"the first compiled assembly of the three-cable arm less a second one {load[1]:.2f} s."
    )
    say()
