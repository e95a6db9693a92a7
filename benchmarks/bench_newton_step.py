"""What a Newton step pays beyond its floor (one assembly + one factorisation), and why.

    python benchmarks/bench_newton_step.py [--out benchmarks/bench_newton_step.txt]

On the three-cable and six-cable arms (default meshes) and the as-built foam member 0,
one process, one BLAS thread, CPU time, compiled assembly:

1. cold solves from rest (no dx/du; commands drawn from the 4-level grid as in
   bench_assembly.py) with the solver as it is; with its chord steps off
   (``lab.fem.solve.statics.CHORD_WINDOW = 0``: every step assembles and factorises); with
   the line search's evaluations in one pass each, the next step's Hessian apart
   (``FUSED_TRIALS = False``); and with whole solves for the condensed step (k + 1
   columns forward and backward, not a forward half with k + 1 and a backward half with
   one), interleaved round by round: CPU per solve, factorisations and steps, the step
   against its floor measured inside the solves (bench_assembly.py's instrumentation:
   the factorisations, and per factorisation one stand-alone assembly at the solves' mean
   cost), and the largest tip difference to the solver as it is;
2. PARDISO's solves with the factorisation of the Hessian at an equilibrium, for 1, 2, 4
   and 7 right-hand sides (a condensed step needs k + 1: the direction and S = H^-1 A)
   and as halves, against the factorisation itself, with the factor's size (iparm(18)):
   a solve reads the factor twice, forward and backward;
3. where a plain Newton step's time goes (chord steps off; instrumented, ms CPU per
   factorisation, medians over rounds): the floor's two parts, then the linear solves, the
   line search's evaluations, the condensed step's own Python (its solves not included),
   the volume limiter's pass and the rest.

Chord steps trade a factorisation for a solve and a line-search evaluation: they lower a
solve's time and raise its cost per factorisation, which is what the ratio divides by.
About 8 minutes at 9 rounds on an idle 2-core machine.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from bench_assembly import FUSED, PHASES, in_solve_floor, instrumented  # noqa: E402
from timing import Printout  # noqa: E402

import lab.fem.solve.linsolve as linsolve  # noqa: E402
import lab.fem.solve.statics as statics  # noqa: E402
from lab.asbuilt.arm import as_built_fem  # noqa: E402
from lab.asbuilt.family import family_member  # noqa: E402
from lab.data.designs import grid_commands  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.fem import ArmFEM, solve_static, use_assembly  # noqa: E402
from lab.fem.solve import steps  # noqa: E402
from lab.fem.solve.linsolve import factorize  # noqa: E402

OUT = Printout()
say = OUT.say


def models() -> dict:
    """name -> (fem, robot): the two cable arms and the foam member."""
    out = {name: (ArmFEM(load_robot(name)), load_robot(name)) for name in ("three-cable", "six-cable")}
    robot = load_robot("three-cable")
    member = family_member(robot, "foam:0")
    out["foam member 0"] = (as_built_fem(robot, member), robot)
    return out


#: The solvers compared: (CHORD_WINDOW, FUSED_TRIALS, condensed steps by forward halves).
SOLVERS = {
    "as it is": (statics.CHORD_WINDOW, True, True),
    "no chord steps": (0.0, True, True),
    "line search's Hessian apart": (statics.CHORD_WINDOW, False, True),
    "whole solves": (statics.CHORD_WINDOW, True, False),
}


def cold(fem, commands, solver: tuple, counts: dict):
    """Cold solves with the ``solver`` of SOLVERS: (solutions, phases s, total s)."""
    saved = statics.CHORD_WINDOW, statics.FUSED_TRIALS, linsolve._Pardiso.half_solves
    statics.CHORD_WINDOW, statics.FUSED_TRIALS, halves = solver
    if not halves:
        linsolve._Pardiso.half_solves = False
    try:
        return instrumented(lambda: [solve_static(fem, u) for u in commands], counts)
    finally:
        statics.CHORD_WINDOW, statics.FUSED_TRIALS, linsolve._Pardiso.half_solves = saved


def chord_table(fems: dict, rounds: int) -> None:
    say("## 1. Cold solves by four solvers (compiled assembly; medians over rounds)")
    say()
    say(
        "| model | solver | CPU per solve, ms | factorisations | steps | step / floor, in the solves | "
        "linear solves, ms per factorisation | energy and gradient, ms per factorisation | "
        "tip difference to the solver as it is, m |"
    )
    say("|---|---|---|---|---|---|---|---|---|")
    for name, (fem, robot) in fems.items():
        n = 3 if name.startswith("foam") else 6
        grid = grid_commands(robot, 4)  # as bench_assembly.py's cold solves
        commands = grid[np.random.default_rng(0).choice(len(grid), n, replace=False)]
        solve_static(fem, commands[0])  # kernels and PARDISO loaded outside the timings
        rows = {label: [] for label in SOLVERS}
        tips = {}
        for r in range(rounds):
            for label in list(SOLVERS)[:: 1 if r % 2 == 0 else -1]:
                counts = {}
                sols, spent, total = cold(fem, commands, SOLVERS[label], counts)
                n_fact = sum(s.factorizations for s in sols)
                rows[label].append(
                    (
                        1e3 * total / len(sols),
                        n_fact,
                        sum(s.iterations for s in sols),
                        total / in_solve_floor(spent, counts, n_fact),
                        1e3 * spent["linear solves"] / n_fact,
                        1e3 * spent["energy and gradient"] / n_fact,
                    )
                )
                tips[label] = np.array([s.p_tip_W for s in sols])
        for label, runs in rows.items():
            med = np.median(np.array(runs), axis=0)
            gap = float(np.max(np.abs(tips[label] - tips["as it is"])))
            say(
                f"| {name} | {label} | {med[0]:.1f} | {int(med[1])} | {int(med[2])} | {med[3]:.2f} | "
                f"{med[4]:.2f} | {med[5]:.2f} | {gap:.1e} |"
            )
    say()
    say(
        f"Energy and gradient: the line search's evaluations without the next step's Hessian ({FUSED} counts "
        "neither there nor in the floor: it is an assembly and an evaluation in one pass)."
    )
    say()


def solve_table(fems: dict, repeats: int) -> None:
    say("## 2. PARDISO's solves against its factorisation, at an equilibrium (ms CPU, mean of repeats)")
    say()
    say(
        "| model | unknowns | entries of the factor | factorisation | 1 RHS | 2 RHS | 4 RHS | 7 RHS | "
        "forward half, 4 RHS | backward half, 1 RHS |"
    )
    say("|---|---|---|---|---|---|---|---|---|---|")
    for name, (fem, robot) in fems.items():
        u = np.full(fem.n_inputs, 0.2 * robot.u_max_rad)
        q = solve_static(fem, u).q
        H = fem.hessian(q, u)
        lu = factorize(H)
        factor_size = -1
        if hasattr(lu, "_solver"):  # PARDISO reports the factor's size at an analysis asked for it
            lu._solver.iparm[17] = -1
            lu.forget_analysis()
            lu = factorize(H)
            factor_size = int(lu._solver.iparm[17])
        t0 = time.process_time()
        for _ in range(repeats):
            lu = factorize(H)
        t_fact = (time.process_time() - t0) / repeats
        cells = []
        for k in (1, 2, 4, 7):
            B = np.random.default_rng(k).normal(size=(H.shape[0], k))
            B = B[:, 0] if k == 1 else B
            t0 = time.process_time()
            for _ in range(repeats * 4):
                lu.solve(B)
            cells.append(1e3 * (time.process_time() - t0) / (repeats * 4))
        B = np.random.default_rng(4).normal(size=(H.shape[0], 4))
        for half, b in ((lu.forward, B), (lu.backward, B[:, 0])):
            t0 = time.process_time()
            for _ in range(repeats * 4):
                half(b)
            cells.append(1e3 * (time.process_time() - t0) / (repeats * 4))
        say(
            f"| {name} | {H.shape[0]:,} | {factor_size:,} | {1e3 * t_fact:.2f} | "
            + " | ".join(f"{c:.2f}" for c in cells)
            + " |"
        )
    say()


def step_breakdown(fems: dict, rounds: int) -> None:
    say("## 3. Where a plain Newton step's time goes (chord steps off; ms CPU per factorisation, medians)")
    say()
    phases = dict(PHASES)
    phases["condensed step (Python)"] = [
        (steps, "condensed_step"),
        (statics, "condensed_step"),
        (steps, "condensed_factorisation"),
    ]
    phases["volume limiter"] = [(ArmFEM, "volume_ratio")]
    shown = [
        "factorisation",
        "Hessian assembly",
        FUSED,
        "linear solves",
        "energy and gradient",
        "condensed step (Python)",
        "volume limiter",
    ]
    say("| model | " + " | ".join(shown) + " | rest | total | step / floor |")
    say("|---|" + "---|" * (len(shown) + 3))
    for name, (fem, robot) in fems.items():
        n = 3 if name.startswith("foam") else 6
        grid = grid_commands(robot, 4)
        commands = grid[np.random.default_rng(0).choice(len(grid), n, replace=False)]
        saved, statics.CHORD_WINDOW = statics.CHORD_WINDOW, 0.0
        rows = []
        try:
            for _ in range(rounds):
                counts = {}
                run = lambda f=fem, c=commands: [solve_static(f, u) for u in c]  # noqa: E731
                sols, spent, total = instrumented(run, counts, phases)
                n_fact = sum(s.factorizations for s in sols)
                per = [1e3 * spent.get(p, 0.0) / n_fact for p in shown]
                rest = 1e3 * total / n_fact - 1e3 * sum(spent.values()) / n_fact
                rows.append([*per, rest, 1e3 * total / n_fact, total / in_solve_floor(spent, counts, n_fact)])
        finally:
            statics.CHORD_WINDOW = saved
        med = np.median(np.array(rows), axis=0)
        say(f"| {name} | " + " | ".join(f"{v:.2f}" for v in med) + " |")
    say()
    say(
        "Hessian assembly: the stand-alone ones (the line search's fused ones in their own column); the "
        "instrumentation itself adds a few microseconds per timed call."
    )
    say()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds of section 1")
    ap.add_argument("--out", help="also write the printout here")
    args = ap.parse_args()
    say(f"command: python benchmarks/{Path(__file__).name} " + " ".join(sys.argv[1:]))
    say(
        f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start; one process, "
        "OMP=1 MKL=1; compiled assembly"
    )
    say()
    with use_assembly("compiled"):
        fems = models()
        chord_table(fems, args.rounds)
        solve_table(fems, 20)
        step_breakdown(fems, args.rounds)
    say(f"load average at the end: {os.getloadavg()[0]:.1f}")
    if args.out:
        OUT.write(args.out)


if __name__ == "__main__":
    main()
