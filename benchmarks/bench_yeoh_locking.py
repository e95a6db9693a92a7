"""Where volumetric locking of linear tets bites for the Yeoh law (silicone) on the arm.

The three-cable arm's geometry (20 cm x 4 cm cylinder, clamped, horizontal) made of
Ecoflex 00-30 with the Yeoh law (lab.fem.materials.yeoh): C10 = 8.4 kPa, C20 = 0.1 kPa,
C30 = 0, the Ecoflex 00-30 sample of the SOROTOKI toolbox (Caasenbrood, Pogromsky and
Nijmeijer, SOROTOKI: a MATLAB toolkit for design, modeling and control of soft robots,
IEEE Access 2024; src/fem/materials/samples/Ecoflex0030.m), and Smooth-On's density of
1070 kg/m^3. Loads: gravity plus the top cable at u_max. Tip under those loads on the
structured meshes n_rings x n_axial = 1x10, 2x20, 3x30 (and a 4x40 reference) for
small-strain Poisson ratios 0.45, 0.47, 0.49 (kappa = 4 C10 (1 + nu) / (3 (1 - 2 nu))).

Locking shows as a coarse mesh that is too stiff, more so as nu -> 1/2: the table gives each
tip's deflection from the rest tip and its distance to the finest mesh's tip at the same nu,
relative to that deflection.

    python benchmarks/bench_yeoh_locking.py [--quick] [--out benchmarks/bench_yeoh_locking.txt]
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from lab.description import load_robot  # noqa: E402
from lab.fem import ArmFEM, YeohMaterial, solve_static, yeoh_matching  # noqa: E402

C10_PA, C20_PA, C30_PA = 8.4e3, 0.1e3, 0.0  # Ecoflex 00-30 (SOROTOKI sample, see above)
DENSITY_KG_M3 = 1070.0  # Smooth-On Ecoflex 00-30 technical bulletin: 1.07 g/cc
NUS = (0.45, 0.47, 0.49)


def tip(robot, nu, n_rings, n_axial, u):
    """Tip (m) at ``u`` (a ramp of warm-started solves), tip (m) under gravity alone, Newton
    steps, wall time (s), node count and the rest tip (m)."""
    fem = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial, material=YeohMaterial(C10_PA, C20_PA, C30_PA, nu))
    t0 = time.perf_counter()
    sol = solve_static(fem, np.zeros(3))
    steps, q, p_g = sol.iterations, sol.q, sol.p_tip_W
    for f in (0.5, 1.0):
        sol = solve_static(fem, f * u, q, raise_on_failure=False)
        steps, q = steps + sol.iterations, sol.q
    p = sol.p_tip_W if sol.converged else np.full(3, np.nan)
    return p, p_g, steps, time.perf_counter() - t0, fem.mesh.n_nodes, fem.tip(fem.X_W)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse meshes: checks the script runs")
    ap.add_argument("--out", type=Path, help="also write the report here")
    args = ap.parse_args()
    lines = []

    def say(line):
        print(line, flush=True)
        lines.append(line)

    robot = dataclasses.replace(load_robot("three-cable"), density_kg_m3=DENSITY_KG_M3)
    u = np.r_[robot.u_max_rad, 0.0, 0.0]
    meshes = [(1, 10), (2, 20)] if args.quick else [(1, 10), (2, 20), (3, 30), (4, 40)]
    say(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; OMP=1 MKL=1")
    say(f"Yeoh C10 = {C10_PA:g} Pa, C20 = {C20_PA:g} Pa, C30 = {C30_PA:g} Pa, density {DENSITY_KG_M3:g} kg/m^3")
    say(f"loads: gravity {robot.gravity_m_s2.tolist()} m/s^2 + top cable at u_max = {robot.u_max_rad} rad")
    say("reference: the finest mesh at the same nu; deflection = |tip - rest tip|")
    say("g: gravity alone; g+c: gravity and the cable")
    head = ("nu", 5), ("kappa/mu", 8), ("mesh", 6), ("nodes", 6), ("g+c tip x, y, z (mm)", 26), ("defl mm", 8)
    head += ("err mm", 7), ("err/defl", 8), ("g defl", 7), ("g err/defl", 10), ("steps", 5), ("s", 6)
    say(" ".join(f"{h:>{w}}" for h, w in head))
    for nu in NUS:
        mu, kappa, _ = yeoh_matching(C10_PA, nu)
        rows = {m: tip(robot, nu, *m, u) for m in meshes}
        ref, ref_g = rows[meshes[-1]][:2]
        for m, (p, p_g, steps, t, nodes, rest) in rows.items():
            defl, err = np.linalg.norm(p - rest), np.linalg.norm(p - ref)
            rel_g = np.linalg.norm(p_g - ref_g) / np.linalg.norm(ref_g - rest)
            xyz = ", ".join(f"{1e3 * v:7.2f}" for v in p)
            rel, defl_g = err / np.linalg.norm(ref - rest), np.linalg.norm(p_g - rest)
            row = f"{nu:5.2f} {kappa / mu:8.1f} {m[0]}x{m[1]:<4d} {nodes:6d} {xyz:>26} {1e3 * defl:8.2f}"
            say(f"{row} {1e3 * err:7.2f} {rel:8.3f} {1e3 * defl_g:7.2f} {rel_g:10.3f} {steps:5d} {t:6.2f}")
    if args.out:
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
