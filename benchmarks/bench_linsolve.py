"""PARDISO's Cholesky-first factorisation against LDL^T only, and finding MKL without a walk.

1. MKL lookup: a fresh process imports ``lab.fem.solve.linsolve`` and factorises a 3 x 3
   matrix, timed (CPU of the process and its children, and wall) around that first
   factorisation: with MKL located directly (:mod:`lab.fem.solve.mkl`) and with
   ``pypardiso``'s own search (``find_library``, then a recursive glob of the environment),
   alternating, ``--spawns`` each.
2. The real Newton Hessians of cold solves (from rest, with dx/du) of the three-cable and
   six-cable arms (default meshes), recorded as the solver factorises them: factorisation
   + one solve with m + 1 right-hand sides (a condensed Newton step's), CPU time, in
   ``PARDISO_MODE`` ``"definite-first"`` (Cholesky, LDL^T where it meets a non-positive
   pivot) against ``"indefinite"`` (LDL^T only, the previous behaviour), the two modes
   alternating over ``--rounds`` rounds; ratio new / old (median over rounds), overall
   and for the positive definite and the indefinite Hessians apart. Also: the largest
   relative difference of the solutions, and whether both modes tell the same Hessians
   indefinite (``n_negative > 0``).
3. The same cold solves end to end, the modes alternating: CPU time per solve (ratio
   new / old), factorisations per solve (equal in both modes?), how often the fallback
   fired, and the largest differences of the tips and tip Jacobians.

    python benchmarks/bench_linsolve.py [--out benchmarks/bench_linsolve.txt] [--quick]

About 3 minutes on 2 shared CPUs, one process, one BLAS thread.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import lab.fem.solve.linsolve as ls  # noqa: E402
import lab.fem.solve.statics  # noqa: E402
import lab.fem.solve.steps  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.fem import ArmFEM, solve_static  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MODES = ("indefinite", "definite-first")  # old, new
#: The first factorisation in a fresh process; argv[1]: "direct" or "walk" (pypardiso's search).
FIRST_USE = """
import json, resource, sys, time
import numpy as np, scipy.sparse as sp, scipy.sparse.linalg
import lab.fem.solve.linsolve as ls, lab.fem.solve.mkl as mkl
if sys.argv[1] == "walk":
    mkl.mkl_rt_path = lambda: None  # as before: pypardiso finds MKL itself
H = sp.csr_matrix(np.array([[4.0, 1, 0], [1, 3, 1], [0, 1, 2]]))
def cpu():  # user + system seconds of this process and its children (find_library's ldconfig)
    usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    return sum(r.ru_utime + r.ru_stime for r in usage)
t0, w0 = cpu(), time.perf_counter()
lu = ls.factorize(H, "pardiso")
t1, w1 = cpu(), time.perf_counter()
print(json.dumps({"cpu": t1 - t0, "wall": w1 - w0, "name": lu.name}))
"""


def first_use(kind):
    """CPU and wall seconds of the first factorisation in a fresh process."""
    env = {k: v for k, v in os.environ.items() if k != "PYPARDISO_MKL_RT"}
    env["PYTHONPATH"] = str(ROOT)
    out = subprocess.run([sys.executable, "-c", FIRST_USE, kind], env=env, capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["name"] == "pardiso", res
    return res["cpu"], res["wall"]


def commands(fem, n, rng):
    """``n`` commands uniform within the bounds that the model accepts."""
    low, high = (np.concatenate(b) for b in zip(*(a.input_bounds() for a in fem.actuators)))
    out = []
    while len(out) < n:
        try:
            out.append(fem.check_input(low + (high - low) * rng.random(len(low))))
        except Exception:  # a description's rule refuses it: draw again
            continue
    return out


class Recorder:
    """Counts (and optionally keeps copies of) the matrices the solver factorises."""

    def __init__(self):
        self.calls, self.kept, self.keep = 0, [], False

    def __enter__(self):
        self.saved = [(m, m.factorize) for m in (lab.fem.solve.steps, lab.fem.solve.statics)]
        for module, fn in self.saved:
            module.factorize = self.wrap(fn)
        return self

    def wrap(self, fn):
        def factorize(H, *a, **k):
            self.calls += 1
            if self.keep:
                self.kept.append(H.copy())  # shifted steps change H in place afterwards
            return fn(H, *a, **k)

        return factorize

    def __exit__(self, *exc):
        for module, fn in self.saved:
            module.factorize = fn


def cold_solve(fem, u, mode):
    """A cold solve with dx/du in ``mode``: (CPU s, solution, factorisations, fallbacks)."""
    ls.PARDISO_MODE = mode
    f0 = ls._Pardiso.fallbacks
    with Recorder() as rec:
        t0 = time.process_time()
        sol = solve_static(fem, u, sensitivity=True)
        dt = time.process_time() - t0
    return dt, sol, rec.calls, ls._Pardiso.fallbacks - f0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", help="also write the printout here")
    ap.add_argument("--quick", action="store_true", help="fewer commands, rounds and spawns")
    ap.add_argument("--commands", type=int, default=4, help="cold solves per arm")
    ap.add_argument("--rounds", type=int, default=5, help="rounds of the alternating timings")
    ap.add_argument("--spawns", type=int, default=5, help="fresh processes per kind of MKL lookup")
    args = ap.parse_args()
    if args.quick:
        args.commands, args.rounds, args.spawns = 1, 2, 2
    lines = []

    def say(text=""):
        print(text, flush=True)
        lines.append(text)

    cmd = "python benchmarks/bench_linsolve.py" + "".join(f" {a}" for a in sys.argv[1:])
    say(f"command: {cmd}")
    say(
        f"machine: {platform.machine()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start; "
        f"one process, OMP={os.environ['OMP_NUM_THREADS']} MKL={os.environ['MKL_NUM_THREADS']}; "
        f"linear solver {ls.default_backend()}"
    )
    if ls.default_backend() != "pardiso":
        say("PARDISO is not available here: nothing to compare.")
        return

    say(f"\n1. first factorisation in a fresh process ({args.spawns} of each, alternating; median [min - max])")
    runs = {"walk": [], "direct": []}
    for i in range(args.spawns):
        for kind in ("walk", "direct") if i % 2 == 0 else ("direct", "walk"):
            runs[kind].append(first_use(kind))
    for kind, label in (("walk", "pypardiso's search (before)"), ("direct", "MKL located directly (after)")):
        cpu, wall = np.array(runs[kind]).T
        say(
            f"  {label:30s} CPU {1e3 * np.median(cpu):7.1f} ms [{1e3 * cpu.min():.1f} - {1e3 * cpu.max():.1f}], "
            f"wall {1e3 * np.median(wall):7.1f} ms"
        )
    cpu_w, cpu_d = (np.median(np.array(runs[k])[:, 0]) for k in ("walk", "direct"))
    t0 = time.process_time()
    for _ in range(20):
        ls.mkl.mkl_rt_path()
    say(
        f"  saved per process: {1e3 * (cpu_w - cpu_d):.0f} ms CPU; the direct lookup itself "
        f"(mkl_rt_path) {1e3 * (time.process_time() - t0) / 20:.1f} ms CPU"
    )

    rng = np.random.default_rng(0)
    for name in ("three-cable", "six-cable"):
        fem = ArmFEM(load_robot(name))
        us = commands(fem, args.commands, rng)
        say(f"\n{name}: default mesh, {fem.n_free} unknowns; {len(us)} cold solves with dx/du (commands seed 0)")
        # The Hessians, as the old mode meets them (the same matrices in either mode).
        ls.PARDISO_MODE = "indefinite"
        with Recorder() as rec:
            rec.keep = True
            for u in us:
                solve_static(fem, u, sensitivity=True)
        mats = rec.kept
        B = np.random.default_rng(1).standard_normal((fem.n_free, len(us[0]) + 1))
        neg = {m: [] for m in MODES}
        x = {m: [] for m in MODES}
        for mode in MODES:
            for H in mats:
                lu = ls._Pardiso(H, mode)
                neg[mode].append(lu.n_negative)
                x[mode].append(lu.solve(B))
        indefinite = np.array(neg["indefinite"]) > 0
        same_signal = np.array_equal(indefinite, np.array(neg["definite-first"]) > 0)
        same_count = neg["indefinite"] == neg["definite-first"]
        rel = max(np.linalg.norm(a - b) / np.linalg.norm(a) for a, b in zip(x["indefinite"], x["definite-first"]))
        say(
            f"  2. {len(mats)} Hessians factorised, {indefinite.sum()} of them indefinite; "
            f"indefinite in both modes alike: {same_signal}, same n_negative: {same_count}; "
            f"solutions differ by at most {rel:.1e} (relative)"
        )
        spent = {m: np.zeros((args.rounds, len(mats))) for m in MODES}
        for r in range(args.rounds):
            for mode in MODES if r % 2 == 0 else MODES[::-1]:
                for j, H in enumerate(mats):
                    t0 = time.process_time()
                    ls._Pardiso(H, mode).solve(B)
                    spent[mode][r, j] = time.process_time() - t0
        everything = np.ones(len(mats), bool)
        for label, sel in (("all", everything), ("positive definite", ~indefinite), ("indefinite", indefinite)):
            n = int(sel.sum())
            if not n:
                continue
            old, new = (spent[m][:, sel].sum(1) for m in MODES)
            say(
                f"     factorisation + solve, {label:17s} ({n:3d}): old {1e3 * np.median(old) / n:6.2f} ms, "
                f"new {1e3 * np.median(new) / n:6.2f} ms per matrix; ratio new/old {np.median(new / old):.3f} "
                f"[{(new / old).min():.3f} - {(new / old).max():.3f}]"
            )
        cpu = {m: np.zeros((args.rounds, len(us))) for m in MODES}
        facts, fallbacks, sols = {m: [] for m in MODES}, [], {m: [] for m in MODES}
        for r in range(args.rounds):
            for k, u in enumerate(us):
                for mode in MODES if (r + k) % 2 == 0 else MODES[::-1]:
                    dt, sol, n_fact, n_fall = cold_solve(fem, u, mode)
                    cpu[mode][r, k] = dt
                    if r == 0:
                        facts[mode].append(n_fact)
                        sols[mode].append(sol)
                        if mode == "definite-first":
                            fallbacks.append(n_fall)
        old, new = (cpu[m].sum(1) for m in MODES)
        d_tip = max(np.abs(a.p_tip_W - b.p_tip_W).max() for a, b in zip(*sols.values()))
        d_jac = max(np.abs(a.J_tip_u - b.J_tip_u).max() / np.abs(a.J_tip_u).max() for a, b in zip(*sols.values()))
        say(
            f"  3. cold solve with dx/du: old {np.median(old) / len(us):.3f} s, new {np.median(new) / len(us):.3f} s "
            f"CPU per solve; ratio new/old {np.median(new / old):.3f} "
            f"[{(new / old).min():.3f} - {(new / old).max():.3f}]"
        )
        say(
            f"     factorisations per solve, old {facts['indefinite']}, new {facts['definite-first']} "
            f"(equal: {facts['indefinite'] == facts['definite-first']}); fallbacks to LDL^T per solve {fallbacks} "
            f"({sum(fallbacks)} of {sum(facts['definite-first'])} factorisations)"
        )
        say(f"     tips differ by at most {d_tip:.1e} m, tip Jacobians by {d_jac:.1e} (relative)")
    ls.PARDISO_MODE = "definite-first"
    say(f"\nload average {os.getloadavg()[0]:.1f} at the end")
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
