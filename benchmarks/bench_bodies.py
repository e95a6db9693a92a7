"""A tapered tentacle against the three-cable arm, and the tentacle's mesh convergence.

1. One static solve from rest of each robot on a structured mesh of about 5,000 nodes
   (n_rings = 5, n_axial = 54: 5,005 nodes), measured in the same run: the tentacle
   (examples/robots/tentacle.toml: tapered, hanging, one tendon at its full 1.5 N) and the
   three-cable arm (one cable at u_max). Wall time, Newton steps and factorisations, and
   the tentacle's time over the arm's.
2. The tentacle's tip under gravity alone and under full tension on one tendon (reached by
   a ramp of warm-started solves), on successively finer meshes, against the finest: the
   table in docs/bodies.md.

    python benchmarks/bench_bodies.py [--quick] [--out benchmarks/bench_bodies.txt]

One BLAS thread (set before numpy is imported). ``--quick`` uses coarser meshes (a check
that the script runs, not the measurement).
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from lab.description import load_robot  # noqa: E402
from lab.fem.model import ArmFEM  # noqa: E402
from lab.fem.solve.statics import solve_static  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TENTACLE = ROOT / "examples" / "robots" / "tentacle.toml"


def timed_solve(robot, u, n_rings, n_axial, repeats=3):
    """Build the FEM, then solve ``u`` from rest ``repeats`` times: the best wall time (s),
    the steps and factorisations of one solve, the node count and the tip (m)."""
    fem = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial)
    best, sol = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = solve_static(fem, u)
        best = min(best, time.perf_counter() - t0)
    return best, sol.iterations, sol.factorizations, fem.mesh.n_nodes, sol.p_tip_W


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse meshes: checks the script runs")
    ap.add_argument("--out", type=Path, help="also write the report here")
    args = ap.parse_args()
    lines = []

    def say(line):
        print(line, flush=True)
        lines.append(line)

    say(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; OMP=1 MKL=1")

    tentacle, arm = load_robot(TENTACLE), load_robot("three-cable")
    size = (2, 12) if args.quick else (5, 54)
    u_tentacle = np.array([tentacle.cables[0].tension_max_n, 0.0])
    u_arm = np.r_[arm.u_max_rad, 0.0, 0.0]
    say(f"1. one static solve from rest, structured mesh n_rings={size[0]}, n_axial={size[1]} (best of 3)")
    rows = {}
    for name, robot, u in (("tentacle, one tendon at 1.5 N", tentacle, u_tentacle), ("three-cable, cable 0 at u_max", arm, u_arm)):  # noqa: E501  # fmt: skip
        t, steps, facts, nodes, _ = timed_solve(robot, u, *size)
        rows[name] = t
        say(f"   {name:32s} {nodes:6,d} nodes  {t:7.3f} s  {steps:3d} steps  {facts:3d} factorisations")
    t_tentacle, t_arm = rows.values()
    say(f"   tentacle / three-cable time: {t_tentacle / t_arm:.2f}")

    meshes = [(1, 6), (2, 12), (3, 24)] if args.quick else [(1, 6), (2, 12), (3, 24), (4, 36), (5, 54), (6, 72)]
    say(f"2. tentacle tip against the finest mesh {meshes[-1]} (mm)")
    tips = {}
    for mesh in meshes:
        fem = ArmFEM(tentacle, n_rings=mesh[0], n_axial=mesh[1])
        rest = solve_static(fem, np.zeros(2))
        q = rest.q
        for f in (1 / 6, 1 / 3, 0.5, 2 / 3, 5 / 6, 1.0):  # a ramp of warm starts: the tip curls a long way
            pulled = solve_static(fem, f * u_tentacle, q, raise_on_failure=False)
            q = pulled.q
        tips[mesh] = (fem.mesh.n_nodes, rest.p_tip_W, pulled.p_tip_W if pulled.converged else np.full(3, np.nan))
        if not pulled.converged:
            say(f"   mesh {mesh}: no equilibrium at {u_tentacle[0]} N ({pulled.status})")
    ref = tips[meshes[-1]]
    say(
        "   | n_rings | n_axial | nodes | gravity: tip x (mm) | gravity: error (mm) | 1.5 N: tip z (mm) | 1.5 N: error (mm) |"  # noqa: E501
    )
    say("   |---|---|---|---|---|---|---|")
    for mesh in meshes:
        nodes, rest, pulled = tips[mesh]
        e_rest = 1e3 * np.linalg.norm(rest - ref[1])
        e_pull = 1e3 * np.linalg.norm(pulled - ref[2])
        say(f"   | {mesh[0]} | {mesh[1]} | {nodes:,d} | {1e3 * rest[0]:.2f} | {e_rest:.2f} | {1e3 * pulled[2]:.2f} | {e_pull:.2f} |")  # noqa: E501  # fmt: skip
    text = "\n".join(lines) + "\n"
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
