"""Static solves against the code of a baseline revision: the solver's speed targets.

    python benchmarks/bench_solve_speed.py --baseline-rev REV [--rounds 3] [--out benchmarks/bench_solve_speed.txt]

The code at ``--baseline-rev`` (from ``git archive``) and this checkout's run in fresh child
processes (one BLAS thread), alternating which goes first round by round. Each child builds
its models and solves once before timing (MKL loading, numba's compilation or cache load and
the meshes are not in the numbers; ``benchmarks/bench_linsolve.py`` and
``benchmarks/bench_assembly.py`` measure those start-up costs), then measures its own CPU
time (``time.process_time``) for

1. cold static solves with dx/du from rest on fixed grid commands: the three-cable and
   six-cable arms (default meshes) and the as-built foam member ``foam:0`` (hyperfoam);
2. a warm data-generation walk (``lab.data.simulation.solve_chunk``, as ``simulate`` runs it)
   on the three-cable and six-cable arms;
3. once, in the new code only: the foam member's whole safe grid with the line search's
   volume limiter (``statics.MIN_VOLUME_RATIO``) on and off.

Per model: the medians over rounds (summed over commands, or per sample), the ratio
new / baseline, the largest tip difference between the versions and the factorisations and
PSD-projected steps of each. About 15 minutes at 3 rounds on 2 idle cores.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from timing import baseline_code

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys, time
import numpy as np
from lab.asbuilt.arm import as_built_fem
from lab.asbuilt.family import family_member
from lab.data import simulation
from lab.data.chunks import grid_chunks
from lab.data.designs import grid_commands
from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static

n_cmd, n_walk = int(sys.argv[1]), int(sys.argv[2])
r3, r6 = load_robot("three-cable"), load_robot("six-cable")
fems = {
    "three-cable": (ArmFEM(r3), r3),
    "six-cable": (ArmFEM(r6), r6),
    "foam member 0": (as_built_fem(r3, family_member(r3, "foam:0")), r3),
}
out = {"cold": {}, "warm": {}}
for name, (fem, robot) in fems.items():
    U = grid_commands(robot, 4)
    U = U[np.random.default_rng(0).choice(len(U), n_cmd, replace=False)]
    solve_static(fem, U[0], sensitivity=True)  # warm-up: not timed
    times, tips, fac, proj = [], [], 0, 0
    for u in U:
        t0 = time.process_time()
        s = solve_static(fem, u, sensitivity=True)
        times.append(time.process_time() - t0)
        tips.append(s.p_tip_W.tolist())
        fac += s.factorizations
        proj += s.projected_steps
    out["cold"][name] = {"s": times, "tips": tips, "factorizations": fac, "projected": proj}
for name in ("three-cable", "six-cable"):
    fem, robot = fems[name]
    simulation._fem = lambda *_, fem=fem: fem  # the default mesh's model, as above
    cmds = grid_commands(robot, 7 if robot.n_inputs == 3 else 3)
    walk = cmds[grid_chunks(robot, cmds)[0].order[:n_walk]]
    simulation.solve_chunk(robot, 0, 0, walk[:2])  # warm-up: the model is built and cached
    t0 = time.process_time()
    res = simulation.solve_chunk(robot, 0, 0, walk)
    per = (time.process_time() - t0) / len(walk)
    out["warm"][name] = {"s": per, "tips": np.asarray(res["p_tip_W"]).tolist(),
                         "factorizations": int(np.sum(res["factorizations"]))}
if len(sys.argv) > 3:  # the volume limiter on and off, in this code, on the foam member's safe grid
    from lab.fem.solve import statics

    fem, robot = fems["foam member 0"]
    U = grid_commands(robot, 4)
    U = U[robot.is_safe(U)]
    for ratio in (statics.MIN_VOLUME_RATIO, 0.0):
        statics.MIN_VOLUME_RATIO = ratio
        t0, proj, with_proj, fac, tips = time.process_time(), 0, 0, 0, []
        for u in U:
            s = solve_static(fem, u)
            proj, with_proj, fac = proj + s.projected_steps, with_proj + (s.projected_steps > 0), fac + s.factorizations
            tips.append(s.p_tip_W)
        out.setdefault("limiter", []).append({"ratio": ratio, "solves": len(U), "projected": proj,
            "with_projected": with_proj, "factorizations": fac, "s": time.process_time() - t0,
            "tips": np.array(tips).tolist()})
print(json.dumps(out))
"""

TARGETS = {"three-cable": 0.55, "six-cable": 0.55, "foam member 0": 0.45}


def child(code_root: Path, cwd: Path, n_cmd: int, n_walk: int, limiter: bool = False) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(code_root), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    r = subprocess.run(
        [sys.executable, "-c", CHILD, str(n_cmd), str(n_walk)] + (["limiter"] if limiter else []),
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        raise SystemExit(f"child on {code_root} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline-rev", required=True, help="git revision to compare against")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--commands", type=int, default=6, help="cold solves per model")
    ap.add_argument("--walk", type=int, default=24, help="commands of the warm walk")
    ap.add_argument("--out", type=Path, help="also write the printout here")
    args = ap.parse_args(argv)
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    lines = [
        f"command: python benchmarks/bench_solve_speed.py --baseline-rev {args.baseline_rev} --rounds {args.rounds}"
        f" --commands {args.commands} --walk {args.walk}",
        f"new: HEAD {head.stdout.strip()} (and the working tree); machine: {os.cpu_count()} CPUs, load average "
        f"{os.getloadavg()[0]:.1f} at the start; one BLAS thread; CPU time of each child process",
    ]
    tmp = Path(tempfile.mkdtemp(prefix="bench-solve-"))
    t_start = time.monotonic()
    try:
        roots = {"baseline": baseline_code(args.baseline_rev, tmp / "baseline"), "new": ROOT}
        runs = {k: [] for k in roots}
        for r in range(args.rounds):
            for k in list(roots)[:: 1 if r % 2 == 0 else -1]:
                limiter = k == "new" and not runs[k]  # once: the foam grid with and without the limiter
                runs[k].append(child(roots[k], tmp, args.commands, args.walk, limiter))
                print(f"round {r + 1}: {k} done", file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    lines += [
        "",
        f"## Cold static solves with dx/du from rest ({args.commands} grid commands; s CPU summed, median of "
        f"{args.rounds} rounds)",
        "| model | baseline s | new s | new / baseline | target | max tip diff m | factorisations base / new | "
        "projected steps base / new |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, target in TARGETS.items():
        t = {k: np.median([np.sum(run["cold"][name]["s"]) for run in runs[k]]) for k in runs}
        c = {k: runs[k][0]["cold"][name] for k in runs}
        tip = np.abs(np.array(c["new"]["tips"]) - np.array(c["baseline"]["tips"])).max()
        lines.append(
            f"| {name} | {t['baseline']:.2f} | {t['new']:.2f} | {t['new'] / t['baseline']:.2f} | <= {target} | "
            f"{tip:.1e} | {c['baseline']['factorizations']} / {c['new']['factorizations']} | "
            f"{c['baseline']['projected']} / {c['new']['projected']} |"
        )
    lines += [
        "",
        f"## Warm data-generation samples (solve_chunk, a grid walk of {args.walk} commands; ms CPU per sample, "
        f"median of {args.rounds} rounds)",
        "| model | baseline ms | new ms | new / baseline | target | max tip diff m | factorisations base / new |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in ("three-cable", "six-cable"):
        t = {k: 1e3 * np.median([run["warm"][name]["s"] for run in runs[k]]) for k in runs}
        w = {k: runs[k][0]["warm"][name] for k in runs}
        tip = np.abs(np.array(w["new"]["tips"]) - np.array(w["baseline"]["tips"])).max()
        lines.append(
            f"| {name} | {t['baseline']:.1f} | {t['new']:.1f} | {t['new'] / t['baseline']:.2f} | <= 0.55 | "
            f"{tip:.1e} | {w['baseline']['factorizations']} / {w['new']['factorizations']} |"
        )
    on, off = runs["new"][0]["limiter"]
    tip = np.abs(np.array(on["tips"]) - np.array(off["tips"])).max()
    lines += [
        "",
        f"## The line search's volume limiter, new code, foam member 0: all {on['solves']} safe commands of the "
        "4-per-input grid, cold solves without dx/du (one run)",
        "| MIN_VOLUME_RATIO | CPU s | factorisations | projected steps | solves with a projected step |",
        "|---|---|---|---|---|",
    ]
    for v in (on, off):
        cells = [v["ratio"], f"{v['s']:.1f}", v["factorizations"], v["projected"], v["with_projected"]]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    lines.append(f"largest tip difference with and without: {tip:.1e} m; CPU ratio {on['s'] / off['s']:.2f}")
    lines += ["", f"wall {time.monotonic() - t_start:.0f} s; load average at the end {os.getloadavg()[0]:.1f}"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
