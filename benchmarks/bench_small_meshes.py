"""From how many tets the compiled kernels pay for loading them: lab.fem.COMPILED_MIN_TETS.

    python benchmarks/bench_small_meshes.py [--out benchmarks/bench_small_meshes.txt]

A process that assembles with the kernels first imports numba and loads them from numba's
cache: measured here in fresh processes (cache warm, 5 each, CPU s, median). Then, in this
process, cold static solves of the three-cable arm on coarse meshes (the sizes the chapters'
quick modes and the tests use) with the NumPy and the compiled assembly, interleaved
(20 commands, the best of 3 rounds, CPU ms per solve), the saving per solve, and the number
of solves that repays the loading. One BLAS thread. About 2 minutes.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from timing import Printout  # noqa: E402

from lab.description import load_robot  # noqa: E402
from lab.fem import COMPILED_MIN_TETS, ArmFEM, solve_static, use_assembly  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MESHES = ((1, 6), (1, 8), (2, 6), (2, 8), (2, 12), (3, 12))
#: A fresh process: build a small model, then time the first compiled assembly (numba imported
#: and the kernels loaded there) and a second one (CPU s).
PROBE = """
import time
from lab.description import load_robot
from lab.fem import ArmFEM, use_assembly
fem = ArmFEM(load_robot("three-cable"), n_rings=1, n_axial=6)
q, u = fem.rest_q(), [0.0, 0.0, 0.0]
with use_assembly("compiled"):
    t0 = time.process_time(); fem.hessian(q, u); t1 = time.process_time(); fem.hessian(q, u); t2 = time.process_time()
print((t1 - t0) - (t2 - t1))
"""
OUT = Printout()
say = OUT.say


def load_cost(runs: int = 5) -> float:
    """CPU s a fresh process spends importing numba and loading the kernels (median)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = [
        float(subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, check=True).stdout)
        for _ in range(runs)
    ]
    return float(np.median(out))


def per_solve(fem, commands, backend: str) -> float:
    """CPU s per cold solve with ``backend``."""
    with use_assembly(backend):
        t0 = time.process_time()
        for u in commands:
            solve_static(fem, u)
        return (time.process_time() - t0) / len(commands)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="also write the printout here")
    args = ap.parse_args()
    say(f"command: python benchmarks/{Path(__file__).name} " + " ".join(sys.argv[1:]))
    say(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start; OMP=1 MKL=1")
    say(f"COMPILED_MIN_TETS = {COMPILED_MIN_TETS}")
    say()
    cost = load_cost()
    say(f"loading numba and the kernels in a fresh process (cache warm, median of 5): {cost:.2f} s CPU")
    say()
    say("| mesh (rings, axial) | tets | NumPy, ms per solve | compiled, ms per solve | saving | solves to repay |")
    say("|---|---|---|---|---|---|")
    robot = load_robot("three-cable")
    rng = np.random.default_rng(0)
    commands = [robot.u_max_rad * rng.uniform(0.0, 0.3, 3) for _ in range(20)]
    for rings, axial in MESHES:
        fem = ArmFEM(robot, n_rings=rings, n_axial=axial)
        for backend in ("numpy", "compiled"):
            per_solve(fem, commands[:2], backend)  # both assemblies ready outside the timing
        best = {b: min(per_solve(fem, commands, b) for _ in range(3)) for b in ("numpy", "compiled")}
        saving = best["numpy"] - best["compiled"]
        repay = f"{cost / saving:.0f}" if saving > 0 else "never"
        say(
            f"| {rings}, {axial} | {len(fem.mesh.tets):,} | {1e3 * best['numpy']:.2f} | {1e3 * best['compiled']:.2f} | "
            f"{1e3 * saving:.2f} ms ({saving / best['numpy']:.0%}) | {repay} |"
        )
    say()
    say(f"load average at the end: {os.getloadavg()[0]:.1f}")
    if args.out:
        OUT.write(args.out)


if __name__ == "__main__":
    main()
