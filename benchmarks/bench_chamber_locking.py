"""Where volumetric locking bites for the pneumatic arm's silicone chambers.

The pneumatic arm (lab/robots/pneumatic-arm.toml: a Yeoh Elastosil M4601 cylinder,
20 cm x 2 cm radius, three unreinforced chambers of radius 4.5 mm) meshed by gmsh at element
sizes h = 5 (the shipped size), 4, 3, 2.5 and 2 mm, at small-strain Poisson ratios 0.45
(the shipped one), 0.47 and 0.49. Loads: gravity alone, then the top chamber at 100 kPa
and at 200 kPa (the description's maximum), each warm-started from the one before. For each
load the table gives the tip's displacement -- from the undeformed tip for gravity, from
the gravity rest pose for pressure -- its ratio to the finest mesh's at the same nu, and the
top chamber's volume over its rest volume. Linear tets lock as nu -> 1/2: a coarse mesh is
too stiff, more so at larger nu.

Then, per nu and load, a Richardson extrapolation over the three finest meshes,
d(h) = d0 + C h^p with the order p fitted (gmsh meshes are not nested, so h is the mean
edge length measured on each mesh, not the nominal size), and what the shipped mesh and
the finest mesh reach of d0.

    python benchmarks/bench_chamber_locking.py [--quick] [--jobs 2] [--out benchmarks/bench_chamber_locking.txt]

About 17 minutes on 2 CPUs (two processes, one BLAS thread each; the 2 mm mesh has ~27,500
nodes and takes most of it). ``--quick`` uses the 6 and 5 mm meshes at nu = 0.45 (a check
that the script runs, not the measurement).
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

SIZES_MM = (5.0, 4.0, 3.0, 2.5, 2.0)
NUS = (0.45, 0.47, 0.49)
PRESSURES_PA = (100e3, 200e3)
CHAMBER = 0  # the top chamber
LOADS = ("gravity", "100 kPa", "200 kPa")


def mean_edge_m(mesh) -> float:
    """The mean length of the mesh's unique tet edges, m."""
    t = mesh.tets
    e = np.concatenate([t[:, [a, b]] for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))])
    e = np.unique(np.sort(e, axis=1), axis=0)
    return float(np.linalg.norm(mesh.X_W[e[:, 0]] - mesh.X_W[e[:, 1]], axis=1).mean())


def run_case(h_mm: float, nu: float) -> dict:
    """Gravity, then the top chamber at each pressure (warm-started), on the h_mm mesh at nu."""
    from lab.description import load_robot
    from lab.fem import ArmFEM, solve_static

    robot = load_robot("pneumatic-arm")
    robot = dataclasses.replace(
        robot, poisson_ratio=nu, body_shape=dataclasses.replace(robot.body_shape, mesh_size_m=h_mm * 1e-3)
    )
    t0 = time.perf_counter()
    fem = ArmFEM(robot)
    act = fem.actuators[0]
    rest = fem.tip(fem.X_W)
    sol = solve_static(fem, np.zeros(3))
    tips, volume, steps = [sol.p_tip_W], [1.0], sol.iterations
    q, u_prev = sol.q, np.zeros(3)
    for p in PRESSURES_PA:
        u = np.zeros(3)
        u[CHAMBER] = p
        sol = solve_static(fem, u, q, raise_on_failure=False)
        if not sol.converged:  # one halfway step, then again
            mid = solve_static(fem, 0.5 * (u + u_prev), q)
            sol = solve_static(fem, u, mid.q, raise_on_failure=False)
            steps += mid.iterations
        steps += sol.iterations
        if sol.converged:
            q, u_prev = sol.q, u
            tips.append(sol.p_tip_W)
            volume.append(float(act.volumes(fem.to_nodes(sol.q))[CHAMBER] / act.V0_m3[CHAMBER]))
        else:
            tips.append(np.full(3, np.nan))
            volume.append(np.nan)
    disp = [np.linalg.norm(tips[0] - rest)] + [np.linalg.norm(t - tips[0]) for t in tips[1:]]
    return dict(
        h_mm=h_mm,
        nu=nu,
        nodes=fem.mesh.n_nodes,
        tets=len(fem.mesh.tets),
        edge_m=mean_edge_m(fem.mesh),
        disp_m=np.array(disp),
        tips=np.array(tips),
        volume=np.array(volume),
        steps=steps,
        time_s=time.perf_counter() - t0,
    )


def richardson(h, d):
    """(d0, p) of d(h) = d0 + C h^p through three points (h decreasing), or why none fits:
    the sequence is not monotone, or its increments do not shrink as h does (no order p in
    (0.1, 8)), or they shrink slower than h (p < 1): the meshes are not in the asymptotic range."""
    (h1, h2, h3), (d1, d2, d3) = h, d
    if not np.all(np.isfinite(d)) or (d1 - d2) * (d2 - d3) <= 0:
        return "not monotone"
    r = (d1 - d2) / (d2 - d3)

    def f(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - r

    lo, hi = 0.1, 8.0
    if f(lo) * f(hi) > 0:
        return "increments grow"
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
    p = 0.5 * (lo + hi)
    if p < 1.0:  # a linear tet's displacement converges at h^2 once asymptotic
        return f"order {p:.2f} < 1"
    c = (d1 - d2) / (h1**p - h2**p)
    return d3 - c * h3**p, p


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="6 and 5 mm meshes at nu = 0.45: checks the script runs")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--out", type=Path, help="also write the report here")
    args = ap.parse_args()
    from joblib import Parallel, delayed

    from lab.fem.solve.linsolve import default_backend

    sizes, nus = ((6.0, 5.0), (0.45,)) if args.quick else (SIZES_MM, NUS)
    lines = []

    def say(line=""):
        print(line, flush=True)
        lines.append(line)

    cases = sorted(((h, nu) for h in sizes for nu in nus), key=lambda c: (c[0], -c[1]))  # slowest first
    t0 = time.perf_counter()
    rows = Parallel(n_jobs=args.jobs)(delayed(run_case)(h, nu) for h, nu in cases)
    wall = time.perf_counter() - t0
    res = {(r["h_mm"], r["nu"]): r for r in rows}

    say(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average "
        f"{os.getloadavg()[0]:.1f} at the end; {args.jobs} worker processes, OMP=1 MKL=1; "
        f"linear solver {default_backend()}"
    )
    say(f"command: python benchmarks/{Path(__file__).name} " + " ".join(sys.argv[1:]))
    say(f"wall time {wall / 60:.1f} min")
    say("pneumatic-arm (Yeoh C10 110 kPa, C20 20 kPa), gmsh meshes at [mesh] size_m = h; top chamber pressurised")
    say("d: tip displacement (mm), from the undeformed tip under gravity, from the gravity pose under pressure")
    say("/fine: d over the finest mesh's d at the same nu; V/V0: the top chamber's volume over its rest volume")
    say("edge: the mesh's mean tet edge length (mm); steps and s: Newton steps and wall time of the case")
    say()
    head = "| nu | h mm | edge mm | nodes | gravity d | /fine | 100 kPa d | /fine | V/V0 | 200 kPa d | /fine | V/V0 |"
    say(head + " steps | s |")
    say("|" + "---|" * (head.count("|") - 1 + 2))
    for nu in nus:
        fine = res[(min(sizes), nu)]["disp_m"]
        for h in sizes:
            r = res[(h, nu)]
            d, v = r["disp_m"], r["volume"]
            cells = [f"{nu:.2f}", f"{h:g}", f"{1e3 * r['edge_m']:.2f}", f"{r['nodes']:,}"]
            for k in range(3):
                cells += [f"{1e3 * d[k]:.3f}", f"{d[k] / fine[k]:.3f}"]
                if k:
                    cells.append(f"{v[k]:.3f}")
            cells += [str(r["steps"]), f"{r['time_s']:.1f}"]
            say("| " + " | ".join(cells) + " |")
    if len(sizes) >= 3:
        say()
        say("Richardson over the three finest meshes (h = mean edge): d0 the extrapolated displacement (mm),")
        say("p the fitted order; shipped: the 5 mm mesh's d at this nu; finest: the finest mesh's d.")
        say("No fit where the increments grow as h shrinks or the order is below 1 (not asymptotic): there the")
        say("displacement still grows with refinement and shipped/finest is an upper bound on shipped/converged.")
        say()
        say("| nu | load | d0 mm | p | shipped/d0 | finest/d0 | shipped/finest |")
        say("|---|---|---|---|---|---|---|")
        for nu in nus:
            fits = [res[(h, nu)] for h in sizes[-3:]]
            hs = [r["edge_m"] for r in fits]
            for k, load in enumerate(LOADS):
                fit = richardson(hs, [r["disp_m"][k] for r in fits])
                shipped = res[(SIZES_MM[0], nu)]["disp_m"][k] if SIZES_MM[0] in sizes else np.nan
                finest = fits[-1]["disp_m"][k]
                if isinstance(fit, str):
                    say(f"| {nu:.2f} | {load} | no fit: {fit} | | | | {shipped / finest:.3f} |")
                    continue
                d0, p = fit
                cells = f"{1e3 * d0:.3f} | {p:.2f} | {shipped / d0:.3f} | {finest / d0:.3f} | {shipped / finest:.3f}"
                say(f"| {nu:.2f} | {load} | {cells} |")
    if args.out:
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
