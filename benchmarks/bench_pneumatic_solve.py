"""The cost of a pneumatic-arm static solve against a three-cable arm's, on meshes of the same size.

The pneumatic arm (lab/robots/pneumatic-arm.toml: Yeoh silicone, three pressure chambers,
gmsh mesh at its [mesh] size_m = 5 mm: 2,685 nodes) and the three-cable arm
(lab/robots/three-cable.toml: neo-Hookean foam, three angle-controlled cables) on the
structured mesh whose node count is closest: n_rings = 4, n_axial = 43, 2,684 nodes. The
same workload on each: 20 commands drawn uniformly within each robot's input bounds (seed
0; 0-200 kPa per chamber, 0-3 rad per motor), solved (a) each from rest and (b) in
sequence, each warm-started from the previous equilibrium (the first from the gravity
pose). Per solve: wall time, factorisations and Newton steps; their median and spread
(min - max), and the ratio of the medians pneumatic / cable. Each workload runs three
times, the robots alternating, and each solve's time is its best of the three (the steps
and factorisations do not change between rounds).

    python benchmarks/bench_pneumatic_solve.py [--quick] [--out benchmarks/bench_pneumatic_solve.txt]

About 4 minutes on 2 CPUs, one process, one BLAS thread. ``--quick``: 4 commands, one round.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from lab.description import load_robot  # noqa: E402
from lab.fem import ArmFEM, solve_static  # noqa: E402
from lab.fem.solve.linsolve import default_backend  # noqa: E402

CABLE_MESH = (4, 43)  # n_rings, n_axial: 61 x 44 = 2,684 nodes, the pneumatic arm's 2,685 less one
N_COMMANDS, ROUNDS, SEED = 20, 3, 0


def bounds(fem):
    """The inputs' lower and upper bounds, actuator by actuator."""
    low, high = zip(*(a.input_bounds() for a in fem.actuators))
    return np.concatenate(low), np.concatenate(high)


def commands(fem, n, rng):
    """``n`` commands uniform within the bounds that the model accepts."""
    low, high = bounds(fem)
    out = []
    while len(out) < n:
        u = low + (high - low) * rng.random(len(low))
        try:
            out.append(fem.check_input(u))
        except Exception:  # a description's rule refuses it: draw again
            continue
    return np.array(out)


def workload(fem, us, q_gravity):
    """(time s, factorisations, steps) per solve: from rest, then warm-started in sequence."""
    out = {"from rest": [], "warm-started": []}
    for u in us:
        t0 = time.perf_counter()
        sol = solve_static(fem, u)
        out["from rest"].append((time.perf_counter() - t0, sol.factorizations, sol.iterations))
    q = q_gravity
    for u in us:
        t0 = time.perf_counter()
        sol = solve_static(fem, u, q)
        out["warm-started"].append((time.perf_counter() - t0, sol.factorizations, sol.iterations))
        q = sol.q
    return {k: np.array(v) for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="4 commands, one round: checks the script runs")
    ap.add_argument("--out", type=Path, help="also write the report here")
    args = ap.parse_args()
    n, rounds = (4, 1) if args.quick else (N_COMMANDS, ROUNDS)
    lines = []

    def say(line=""):
        print(line, flush=True)
        lines.append(line)

    rng = np.random.default_rng(SEED)
    fems = {
        "pneumatic": ArmFEM(load_robot("pneumatic-arm")),
        "cable": ArmFEM(load_robot("three-cable"), n_rings=CABLE_MESH[0], n_axial=CABLE_MESH[1]),
    }
    us = {k: commands(f, n, rng) for k, f in fems.items()}
    q_g = {k: solve_static(f, np.zeros(f.n_inputs)).q for k, f in fems.items()}
    results = {k: [] for k in fems}
    for r in range(rounds):
        for k in list(fems)[:: 1 if r % 2 == 0 else -1]:
            results[k].append(workload(fems[k], us[k], q_g[k]))
    best = {}
    for k, runs in results.items():
        best[k] = {}
        for mode in runs[0]:
            a = runs[0][mode].copy()
            a[:, 0] = np.min([run[mode][:, 0] for run in runs], axis=0)
            best[k][mode] = a

    say(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average "
        f"{os.getloadavg()[0]:.1f} at the end; one process, OMP=1 MKL=1; linear solver {default_backend()}"
    )
    say(f"command: python benchmarks/{Path(__file__).name} " + " ".join(sys.argv[1:]))
    p, c = fems["pneumatic"], fems["cable"]
    say(
        f"pneumatic-arm: gmsh mesh at {p.robot.body_shape.mesh_size_m * 1e3:g} mm, {p.mesh.n_nodes:,} nodes, "
        f"{len(p.mesh.tets):,} tets, {p.n_free:,} free dofs; inputs {list(p.input_names)} in "
        f"[{bounds(p)[0][0]:g}, {bounds(p)[1][0]:g}] Pa"
    )
    say(
        f"three-cable: structured mesh n_rings = {CABLE_MESH[0]}, n_axial = {CABLE_MESH[1]}, {c.mesh.n_nodes:,} nodes, "
        f"{len(c.mesh.tets):,} tets, {c.n_free:,} free dofs; inputs {list(c.input_names)} in "
        f"[{bounds(c)[0][0]:g}, {bounds(c)[1][0]:g}] rad"
    )
    say(
        f"{n} commands uniform in the bounds (seed {SEED}), each solved from rest and then in sequence warm-started "
        f"(the first from the gravity pose); time per solve: best of {rounds} rounds"
    )
    say("median [min - max] per solve; ratio: pneumatic median / cable median")
    say()
    say("| start | quantity | pneumatic arm | three-cable arm | ratio |")
    say("|---|---|---|---|---|")
    for mode in ("from rest", "warm-started"):
        for j, (name, fmt) in enumerate((("time (s)", ".3f"), ("factorisations", ".0f"), ("Newton steps", ".0f"))):
            cells, med = [], []
            for k in ("pneumatic", "cable"):
                v = best[k][mode][:, j]
                med.append(np.median(v))
                cells.append(f"{np.median(v):{fmt}} [{v.min():{fmt}} - {v.max():{fmt}}]")
            say(f"| {mode} | {name} | {cells[0]} | {cells[1]} | {med[0] / med[1]:.2f} |")
    say()
    for k in ("pneumatic", "cable"):
        tot = {mode: best[k][mode][:, 0].sum() for mode in best[k]}
        say(f"{k}: workload total {tot['from rest']:.1f} s from rest, {tot['warm-started']:.1f} s warm-started")
    if args.out:
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
