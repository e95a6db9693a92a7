"""Compiled element kernels (lab.fem.kernels) against the NumPy reference assembly.

    python benchmarks/bench_assembly.py --baseline-rev REV [--quick] [--out benchmarks/bench_assembly.txt]

On the three-cable and six-cable arms (default meshes), an as-built foam member
(``twin:foam:0``: the hyperfoam law on its emulator mesh) and the pneumatic arm (Yeoh,
pressure chambers), one process, one BLAS thread, CPU time (time.process_time), the two
assemblies interleaved round by round, medians:

1. assembly at an equilibrium: element Hessians, the actuators' blocks, the whole Hessian,
   gradient and energy, reference and compiled, and their ratio;
2. cold static solves with dx/du from rest: CPU ratio, largest tip difference, factorisations;
3. warm data-generation samples (lab.data.simulation.solve_chunk along a grid walk);
4. the Newton step against its floor, one assembly + one factorisation (compiled), and
   where a cold solve's and a warm sample's time goes, per factorisation and per sample;
5. why foam solves take PSD-projected steps: the exact Hessian at the first iterate where
   it is indefinite (PARDISO's inertia, the most negative element eigenvalue, det F);
6. the command line's cold start, ``python -m lab --help`` and a tiny ``simulate`` in fresh
   processes, before (the code at ``--baseline-rev``, from ``git archive``) and after, with
   numba's cache warm and empty (child CPU time, 5 runs each).

About 30 minutes on 2 loaded cores; ``--quick``: fewer commands and rounds, no cold start.
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
from assembly_startup import cold_start  # noqa: E402

import lab.data.simulation as simulation  # noqa: E402
import lab.fem.solve.linsolve as linsolve  # noqa: E402
import lab.fem.solve.statics as statics  # noqa: E402
import lab.fem.solve.steps as steps  # noqa: E402
from lab.asbuilt.arm import as_built_fem  # noqa: E402
from lab.asbuilt.family import family_member  # noqa: E402
from lab.data.chunks import grid_chunks  # noqa: E402
from lab.data.designs import grid_commands  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.fem import ArmFEM, solve_static, use_assembly  # noqa: E402
from lab.fem.kernels import COMPILED_MIN_TETS, compiled_law  # noqa: E402
from lab.fem.solve.linsolve import default_backend, factorize  # noqa: E402
from lab.fem.solve.warmstart import WalkPredictor  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BOTH = ("numpy", "compiled")
LINES: list[str] = []


def say(text: str = "") -> None:
    print(text, flush=True)
    LINES.append(text)


def cpu(fn, n: int = 1) -> float:
    """Median CPU seconds of n calls of fn()."""
    times = []
    for _ in range(n):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return float(np.median(times))


def paired(fns: dict, rounds: int, n: int) -> dict:
    """Each assembly's median CPU seconds of fns[name][assembly], the two interleaved."""
    out = {key: [] for key in fns}
    for r in range(rounds):
        for b in BOTH[:: 1 if r % 2 == 0 else -1]:
            with use_assembly(b):
                for name, fn in fns.items():
                    out[name].append((b, cpu(fn, n)))
    return {name: {b: float(np.median([t for bb, t in v if bb == b])) for b in BOTH} for name, v in out.items()}


def models() -> dict:
    r3, r6, rp = load_robot("three-cable"), load_robot("six-cable"), load_robot("pneumatic-arm")
    return {
        "three-cable": (ArmFEM(r3), np.array([2.0, 1.0, 0.5]), r3),
        "six-cable": (ArmFEM(r6), np.array([1.0, 0.5, 0.2, 0.0, 0.3, 0.1]), r6),
        "foam member 0": (as_built_fem(r3, family_member(r3, "foam:0")), np.array([2.0, 1.0, 0.5]), r3),
        "pneumatic arm": (ArmFEM(rp), np.array([1.0e5, 0.0, 5.0e4]), rp),
    }


def assembly_times(fem, u, rounds: int):
    """(q, {quantity: {assembly: s}}) at the equilibrium of ``u``."""
    q = solve_static(fem, u).q
    x = fem.to_nodes(q)
    with use_assembly("compiled"):
        law = compiled_law(fem.elastic)
    data, slots = np.zeros(fem._pattern.nnz), fem._pattern.element_slots

    def elements():
        return fem.elastic.hessian(x) if fem._sums() is fem.elastic else law.add_hessian(x, data, slots)

    fns = {
        "element Hessians": elements,
        "actuator blocks": lambda: [a.hessian_blocks(x, ua) for a, ua in fem._split(u)],
        "whole Hessian": lambda: fem.hessian(q, u),
        "gradient": lambda: fem.gradient(q, u),
        "energy": lambda: fem.energy(q, u),
    }
    return q, paired(fns, rounds, 3 if len(fem.elastic.V) > 5000 else 7)


def assembly(fems: dict, rounds: int) -> dict:
    say("## 1. Assembly at an equilibrium (ms CPU, median; ratio compiled / reference)")
    say()
    say("| model | law, tets | quantity | reference | compiled | ratio |")
    say("|---|---|---|---|---|---|")
    out = {}
    for name, (fem, u, _) in fems.items():
        q, t = assembly_times(fem, u, rounds)
        out[name] = (fem, u, q, t)
        tag = f"{type(fem.elastic).__name__}, {len(fem.elastic.V):,}"
        for quantity, v in t.items():
            ref, new = 1e3 * v["numpy"], 1e3 * v["compiled"]
            say(f"| {name} | {tag} | {quantity} | {ref:.2f} | {new:.2f} | {new / ref:.2f} |")
    say()
    say(
        "(element Hessians: the reference's (M, 12, 12) blocks; the compiled ones are also added into the "
        "CSR data. Actuator blocks: the same NumPy code in both, the cables' or the chambers'.)"
    )
    say()
    return out


def cold_solves(fems: dict, n_cmd: int, rounds: int, seed: int = 0) -> dict:
    say("## 2. Cold static solves with dx/du, from rest (s CPU per solve, median over rounds, summed over commands)")
    say()
    say("| model | commands | reference | compiled | ratio | max tip diff (m) | factorisations ref / compiled |")
    say("|---|---|---|---|---|---|---|")
    out = {}
    for name, (fem, _, robot) in fems.items():
        U = grid_commands(robot, 4)
        U = U[np.random.default_rng(seed).choice(len(U), n_cmd, replace=False)]
        times, sols = {b: np.zeros(n_cmd) for b in BOTH}, {}
        for i, u in enumerate(U):
            runs = {b: [] for b in BOTH}
            for r in range(rounds):
                for b in BOTH[:: 1 if r % 2 == 0 else -1]:
                    with use_assembly(b):
                        t0 = time.process_time()
                        sols[b, i] = solve_static(fem, u, sensitivity=True)
                        runs[b].append(time.process_time() - t0)
            for b in BOTH:
                times[b][i] = np.median(runs[b])
        tip = max(np.abs(sols["numpy", i].p_tip_W - sols["compiled", i].p_tip_W).max() for i in range(n_cmd))
        fac = {b: sum(sols[b, i].factorizations for i in range(n_cmd)) for b in BOTH}
        ref, new = times["numpy"].sum(), times["compiled"].sum()
        say(
            f"| {name} | {n_cmd} | {ref:.2f} | {new:.2f} | {new / ref:.2f} | {tip:.1e} | {fac['numpy']} / "
            f"{fac['compiled']} |"
        )
        out[name] = (U, times, sols)
    say()
    return out


def warm_samples(fems: dict, n_walk: int, rounds: int) -> None:
    say(f"## 3. Warm data-generation samples (solve_chunk along a grid walk of {n_walk} commands; ms CPU per sample)")
    say()
    say("| model | reference | compiled | ratio | max tip diff (m) | factorisations ref / compiled |")
    say("|---|---|---|---|---|---|")
    for name, (fem, _, robot) in fems.items():
        cmds = grid_commands(robot, 7 if robot.n_inputs == 3 else 3)
        walk = cmds[grid_chunks(robot, cmds)[0].order[:n_walk]]
        original = simulation._fem
        simulation._fem = lambda *_, fem=fem: fem  # the member's FEM, not the description's
        try:
            runs, res = {b: [] for b in BOTH}, {}
            for r in range(rounds):
                for b in BOTH[:: 1 if r % 2 == 0 else -1]:
                    with use_assembly(b):
                        t0 = time.process_time()
                        res[b] = simulation.solve_chunk(robot, 0, 0, walk)
                        runs[b].append((time.process_time() - t0) / len(walk))
        finally:
            simulation._fem = original
        ref, new = 1e3 * np.median(runs["numpy"]), 1e3 * np.median(runs["compiled"])
        tip = np.abs(res["numpy"]["p_tip_W"] - res["compiled"]["p_tip_W"]).max()
        fac = [int(res[b]["factorizations"].sum()) for b in BOTH]
        say(f"| {name} | {ref:.1f} | {new:.1f} | {new / ref:.2f} | {tip:.1e} | {fac[0]} / {fac[1]} |")
    say()


PHASES = {  # name: where the solver looks each timed function up
    "Hessian assembly": [(ArmFEM, "hessian")],
    "factorisation": [(steps, "factorize"), (statics, "factorize")],
    "linear solves": [
        (linsolve._Pardiso, "solve"),
        (linsolve._Pardiso, "forward"),
        (linsolve._Pardiso, "backward"),
        (linsolve._SuperLU, "solve"),
    ],
    "energy and gradient": [(ArmFEM, "energy"), (ArmFEM, "gradient")],
    "Hessian products": [(ArmFEM, "hessian_operator")],
    "warm-start predictions": [(WalkPredictor, "ranked")],
}
#: A line-search evaluation with the next step's Hessian (``ArmFEM.energy(..., with_hessian=True)``)
#: is timed apart from PHASES' "energy and gradient": it is an assembly and an evaluation at once.
FUSED = "Hessian with the trial's energy and gradient"


def instrumented(fn, counts: dict | None = None, phases: dict | None = None):
    """fn() with the PHASES (or ``phases``) timed (CPU, exclusive of nested phases): (result,
    {phase: s}, total s); the calls of each phase counted into ``counts`` if given. A fused
    line-search evaluation (``with_hessian``) is timed as FUSED."""
    spent, stack, originals = {}, [], []
    counts = {} if counts is None else counts

    def timed(name, f):
        def wrapper(*a, **k):
            stack.append(0.0)
            t0 = time.process_time()
            try:
                return f(*a, **k)
            finally:
                dt = time.process_time() - t0
                inner = stack.pop()
                key = FUSED if k.get("with_hessian") else name
                spent[key] = spent.get(key, 0.0) + dt - inner
                counts[key] = counts.get(key, 0) + 1
                if stack:
                    stack[-1] += dt

        return wrapper

    for name, targets in (PHASES if phases is None else phases).items():
        for owner, attr in targets:
            originals.append((owner, attr, getattr(owner, attr)))
            setattr(owner, attr, timed(name, getattr(owner, attr)))
    try:
        t0 = time.process_time()
        out = fn()
        total = time.process_time() - t0
    finally:
        for owner, attr, f in originals:
            setattr(owner, attr, f)
    return out, spent, total


def in_solve_floor(spent: dict, counts: dict, n_fact: int) -> float:
    """The floor of ``n_fact`` Newton steps as the solves pay it (s): their factorisations,
    and as many assemblies at the mean cost of a stand-alone one in those solves (a fused
    line-search evaluation assembles too, but also evaluates: it is not the floor's)."""
    assembly = spent.get("Hessian assembly", 0.0) / max(counts.get("Hessian assembly", 0), 1)
    return spent.get("factorisation", 0.0) + n_fact * assembly


def floor(asm: dict, cold: dict) -> None:
    say("## 4. The Newton step against its floor, and where the time goes (compiled)")
    say()
    say(
        "Newton step: a cold solve's CPU (no dx/du) over its factorisations; floor: one whole-Hessian assembly "
        "+ one factorisation (ms CPU, medians)"
    )
    say()
    say("| model | assembly | factorisation | floor | Newton step | step / floor | the same, unprojected solves |")
    say("|---|---|---|---|---|---|---|")
    with use_assembly("compiled"):
        for name, (U, _, _) in cold.items():
            fem, u, q, t = asm[name]
            H = fem.hessian(q, u)
            t_fact = cpu(lambda H=H: factorize(H), 5)
            t_asm = t["whole Hessian"]["compiled"]
            per, plain = [], []
            for u_c in U:
                t0 = time.process_time()
                s = solve_static(fem, u_c)
                per.append((time.process_time() - t0) / s.factorizations)
                if not s.projected_steps:
                    plain.append(per[-1])
            step, unit = float(np.median(per)), t_asm + t_fact
            alone = f"{np.median(plain) / unit:.2f} ({len(plain)} of {len(U)})" if plain else f"none of {len(U)}"
            say(
                f"| {name} | {1e3 * t_asm:.2f} | {1e3 * t_fact:.2f} | {1e3 * unit:.2f} | {1e3 * step:.2f} | "
                f"{step / unit:.2f} | {alone} |"
            )
        say()
        say("Where the time goes (instrumented runs; ms CPU per factorisation for cold solves, per sample for a walk):")
        say()
        phases = [*PHASES, FUSED]
        say("| run | " + " | ".join(phases) + " | rest | total | total / (assembly + factorisation) |")
        say("|---|" + "---|" * (len(phases) + 3))
        for name, (U, _, _) in cold.items():
            fem, counts = asm[name][0], {}
            sols, spent, total = instrumented(lambda fem=fem, U=U: [solve_static(fem, u_c) for u_c in U], counts)
            per = sum(s.factorizations for s in sols)
            row = [1e3 * spent.get(p, 0.0) / per for p in phases]
            rest = 1e3 * total / per - sum(row)
            cells = " | ".join(f"{v:.2f}" for v in row)
            in_situ = total / in_solve_floor(spent, counts, per)
            say(f"| {name}, cold solve | {cells} | {rest:.2f} | {1e3 * total / per:.2f} | {in_situ:.2f} |")
        robot = load_robot("three-cable")
        cmds = grid_commands(robot, 7)
        walk = cmds[grid_chunks(robot, cmds)[0].order[:24]]
        simulation._FEM_CACHE.clear()
        simulation.solve_chunk(robot, robot.n_rings, robot.n_axial, walk[:2])  # build the FEM outside the timing
        _, spent, total = instrumented(lambda: simulation.solve_chunk(robot, robot.n_rings, robot.n_axial, walk))
        row = [1e3 * spent.get(p, 0.0) / len(walk) for p in phases]
        rest = 1e3 * total / len(walk) - sum(row)
        say(
            f"| three-cable, warm sample ({len(walk)}) | " + " | ".join(f"{v:.2f}" for v in row) + f" | {rest:.2f} | "
            f"{1e3 * total / len(walk):.2f} | |"
        )
    say()
    say(
        "The last column is the Newton step against its floor measured inside the solves (each factorisation where "
        "the solver makes it, and per factorisation one assembly at the mean cost of the solves' stand-alone ones; "
        "the table above factorises one matrix five times over, with its data in the cache, and times the solves "
        "apart from it: a smaller floor and a noisier step). A line-search evaluation far from the equilibrium "
        "assembles the next step's Hessian in the same pass (its own column)."
    )
    say()


def projection(fem, robot, n_cmd: int, seed: int = 1) -> None:
    say("## 5. Why foam solves take PSD-projected steps (compiled; the solver instrumented, not changed)")
    say()
    U = grid_commands(robot, 4)
    U = U[np.random.default_rng(seed).choice(len(U), n_cmd, replace=False)]
    log, last_q = [], {}
    newton, hessian = statics.newton_step, fem.hessian

    def watched_hessian(q, u, project=False):
        if not project:
            last_q["q"], last_q["n"] = q, last_q["n"] + 1
        return hessian(q, u, project)

    def watched_newton(H, g, cond):
        d, fac = newton(H, g, cond)
        if d is None:
            log.append((H, last_q["q"], last_q["n"]))
        return d, fac

    def min_det(q):
        return np.linalg.det(fem.elastic.deformation_gradient(fem.to_nodes(q))).min()

    fem.hessian, statics.newton_step = watched_hessian, watched_newton
    rows, projected, facts, J_eq = [], 0, 0, []
    try:
        with use_assembly("compiled"):
            law = compiled_law(fem.elastic)
            for u in U:
                log.clear()
                last_q["n"] = 0
                s = solve_static(fem, u)
                projected, facts = projected + s.projected_steps, facts + s.factorizations
                J_eq.append(min_det(s.q))
                for H, q, n in log:
                    w = np.linalg.eigvalsh(law.hessian(fem.to_nodes(q)))[:, 0]
                    diag = np.median(H.diagonal())
                    away = np.abs(q - fem.rest_q()).max()
                    rows.append((factorize(H).n_negative, w.min(), w.min() / diag, diag, min_det(q), away, n))
                    if w.min() < last_q.get("worst", (0.0,))[0]:
                        last_q["worst"] = (w.min(), int(np.argmin(w)))
                if log and "cost" not in last_q:
                    q = log[0][1]
                    last_q["cost"] = [cpu(lambda p=p, q=q, u=u: hessian(q, u, p), 3) for p in (False, True)]
    finally:
        del fem.hessian
        statics.newton_step = newton
    el = fem.elastic
    say(
        f"The member's law: hyperfoam, alpha = {el.alpha:.2f}, beta = {el.beta:.2f} (alpha beta = "
        f"{el.alpha * el.beta:.1f}); {len(el.V):,} tets. {n_cmd} cold solves from rest: {facts} factorisations, "
        f"{len(rows)} Newton steps refused (the exact Hessian not positive definite, or its step no descent "
        f"direction), {projected} of them ended in a projected step (the diagonal shifts {steps.SHIFTS} x the "
        "median diagonal did not make it definite)."
    )
    if rows:
        r = np.array(rows)

        def span(k, fmt):
            return f"{format(r[:, k].min(), fmt)} to {format(r[:, k].max(), fmt)}"

        say()
        say(
            f"At those iterates: PARDISO counts {span(0, '.0f')} negative eigenvalues; the most negative eigenvalue of "
            f"an element Hessian is {span(1, '.3g')} N/m, {span(2, '.3g')} times the median diagonal entry "
            f"({span(3, '.0f')} N/m); the smallest det F of a tet is {span(4, '.2f')} (at the equilibria: "
            f"{min(J_eq):.2f} to {max(J_eq):.2f}); the iterates are {1e3 * r[:, 5].min():.1f} to "
            f"{1e3 * r[:, 5].max():.1f} mm from rest, each at assembly {r[:, 6].min():.0f} to {r[:, 6].max():.0f} "
            f"of its solve (assembly 1 is at rest). The most negative element eigenvalue is in a tet "
            f"{_eyelet_distance(fem, last_q['worst'][1]):.1f} mm from the nearest eyelet. There a projected assembly "
            f"costs {1e3 * last_q['cost'][1]:.0f} "
            f"ms CPU against {1e3 * last_q['cost'][0]:.1f} ms for the exact one (the eigen-decomposition of every "
            "12 x 12 element block)."
        )
    say()


def _eyelet_distance(fem, tet: int) -> float:
    """Distance (mm) from a tet's rest centroid to the nearest eyelet (via point) of any cable."""
    eyelets = np.vstack([r.points(fem.X_W)[1:] for a in fem.actuators for r in getattr(a, "routes", [])])
    centroid = fem.X_W[fem.mesh.tets[tet]].mean(axis=0)
    return 1e3 * float(np.linalg.norm(eyelets - centroid, axis=1).min())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline-rev", help="git revision before the kernels, for the cold start (else skipped)")
    ap.add_argument("--quick", action="store_true", help="fewer commands and rounds, no cold start")
    ap.add_argument("--out", help="also write the printout here")
    args = ap.parse_args()
    rounds, n_cmd, n_walk = (1, 2, 6) if args.quick else (5, 4, 16)
    say(f"command: python benchmarks/{Path(__file__).name} " + " ".join(sys.argv[1:]))
    cpu_name = next(
        (ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")),
        platform.machine(),
    )
    say(
        f"machine: {cpu_name}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start; one "
        f"process, OMP=1 MKL=1; linear solver {default_backend()}; numba {__import__('numba').__version__}; "
        f"kernels by default from {COMPILED_MIN_TETS:,} tets"
    )
    say()
    fems = models()
    for fem, _, _ in fems.values():  # load (or compile) each law's kernels outside the timings
        with use_assembly("compiled"):
            fem.hessian(fem.rest_q(), np.zeros(fem.n_inputs))
            fem.gradient(fem.rest_q(), np.zeros(fem.n_inputs))
    asm = assembly(fems, rounds)
    solvers = {k: v for k, v in fems.items() if k != "pneumatic arm"}
    cold = cold_solves(solvers, n_cmd, rounds)
    warm_samples({k: v for k, v in solvers.items() if k != "six-cable"}, n_walk, rounds)
    floor(asm, cold)
    projection(fems["foam member 0"][0], fems["foam member 0"][2], 2 * n_cmd)
    if args.baseline_rev and not args.quick:
        cold_start(args.baseline_rev, say)
    say(f"load average at the end: {os.getloadavg()[0]:.1f}")
    if args.out:
        Path(args.out).write_text("\n".join(LINES) + "\n")


if __name__ == "__main__":
    main()
