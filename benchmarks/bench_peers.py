"""Our FEM and IK side by side with what users would pick instead: MuJoCo, and SciPy for the IK.

    python benchmarks/bench_peers.py            # default mesh, 28 commands, circle of 100 (~17 minutes)
    python benchmarks/bench_peers.py --quick    # coarse mesh, 8 commands, 20 targets (~1 minute)
    python benchmarks/bench_peers.py --only-skfem   # only the scikit-fem section (~1 minute)

Physics: :func:`lab.peers.mujoco_arm` builds the arm in MuJoCo 4 on the same tet mesh (flex
elasticity with our E, nu and lumped masses; each cable a tension-only spatial tendon through
sites at our via points, each site riding on the nearest node of its tet). For the five
commands of benchmarks/mesh_refinement.py, three small ones (0.1 rad on every cable plus 0.3 rad
on one, where the two material laws agree) and 20 Sobol commands it measures the tip distance between
MuJoCo's settled state and our static equilibrium; MuJoCo's time to settle (every node slower
than V_TOL for HOLD_S simulated seconds) from rest and from the previous command's settled
state, against our static solve from rest and warm-started from the previous equilibrium; and
the tip Jacobian, ours by sensitivity analysis, MuJoCo's by central differences of settled
states (+-H_RAD on each motor, from the settled state). One thread (OMP/MKL = 1).

The material alone: with the cables 1 cm slack, gravity sag and a 5 or 50 mN tip load, ours
against MuJoCo's flex. (torch-fem, the issue's candidate for this part, does not fit the pinned
environment: every release with a hyperelastic material, 0.4 to 0.14.0, imports pyvista at
``import torchfem``, which needs vtk, a 140 MB wheel; 0.3.8 imports it lazily but has only
small-strain materials. Its adjoint gradient is therefore not compared.)

A second tet FEM with a neo-Hookean material: :class:`lab.peers.SkfemArm`, the arm's body in
scikit-fem (pure Python, numpy and scipy only) on the same mesh with our compressible
neo-Hookean law written as its forms (so the two FEMs discretise the same energy and should
agree to the solvers' tolerances), Newton with its assembled residual and tangent. Gravity sag
and a 5 and 50 mN downward load on the tip node (cables 1 cm slack): tip displacement, time of
a static solve from rest (best of 3), and d p_tip / d F (mm/N): ours by one solve with our
exact Hessian, scikit-fem's by the adjoint method with its tangent, and central differences
(h = 0.1 mN) of each. The cables are not compared: scikit-fem has no one-sided cable.
``--skip-skfem`` leaves that section out, ``--only-skfem`` runs only it.

IK: the learned model data/model_sim_three_cable.npz on the circle, warm-started point to
point: lab's bounded LM against scipy.optimize.least_squares (trf, box bounds, the model's
analytic Jacobian) and scipy.optimize.minimize (L-BFGS-B), each at SciPy's default tolerances,
at the loosest tried that reach our residual, and tight; best of 3 passes each.
"""

import os

for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):  # one thread, as stated,
    os.environ.setdefault(_var, "1")  # also when the caller's shell does not set it

import argparse  # noqa: E402
import copy  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import least_squares, minimize  # noqa: E402

from lab.control.command_set import CommandSet  # noqa: E402
from lab.control.ik import IKConfig, IKSolver, grid_seeds  # noqa: E402
from lab.control.trajectories import circle  # noqa: E402
from lab.data.designs import sobol_commands  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.fem.model import ArmFEM  # noqa: E402
from lab.fem.solve.statics import sensitivities, solve_static  # noqa: E402
from lab.learn.mlp import load_model  # noqa: E402
from lab.peers import SkfemArm, lab_loaded_arm, lab_tip_load_gradient, mujoco_arm  # noqa: E402

V_TOL = 1e-4  # m/s: a node this slow is ~4 um from rest on the softest bending mode (~25 rad/s)
HOLD_S = 0.1  # s simulated: longer than a quarter period of that mode, so no turning point counts
MAX_SIM_S = 5.0  # s simulated before a run counts as not settled
H_RAD = 0.05  # central-difference step of MuJoCo's Jacobian (tip moves ~1 mm)
REACH_M = 1e-5  # an IK answer farther than this from its target is a failure

ap = argparse.ArgumentParser()
ap.add_argument("--quick", action="store_true", help="coarse mesh, 3 Sobol commands, 20 targets")
ap.add_argument("--model", default="data/model_sim_three_cable.npz")
ap.add_argument("--skip-skfem", action="store_true", help="leave out the scikit-fem section")
ap.add_argument("--only-skfem", action="store_true", help="run only the scikit-fem section")
args = ap.parse_args()
print(f"threads per process: OMP={os.environ.get('OMP_NUM_THREADS')} MKL={os.environ.get('MKL_NUM_THREADS')}")
robot = load_robot("three-cable")
n_sobol, n_targets = (3, 20) if args.quick else (20, 100)
fem = ArmFEM(robot, n_rings=2, n_axial=10) if args.quick else ArmFEM(robot)


def best_of(n, fn):
    """(result of the last call, least wall time in s) of ``n`` calls of ``fn()``."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, min(times)


def skfem_section():
    """Our FEM against scikit-fem on the body alone (cables slack); prints its table."""
    import skfem

    H_N = 1e-4  # central-difference step of d p_tip / d F (N): moves the tip ~40 um
    sk = SkfemArm(fem)
    sk.solve(0.0), solve_static(lab_loaded_arm(fem, 0.0), np.zeros(3))  # first-call costs out
    p0, rows = fem.tip(fem.X_W), []
    for what, F_n in (("gravity sag", 0.0), ("gravity + 5 mN tip load", 5e-3), ("gravity + 50 mN tip load", 50e-3)):
        arm = lab_loaded_arm(fem, F_n)
        ours, t_ours = best_of(3, lambda: solve_static(arm, np.zeros(3)))  # noqa: B023
        theirs, t_sk = best_of(3, lambda: sk.solve(F_n))  # noqa: B023
        slack = bool(np.all(arm.cable_tensions(arm.to_nodes(ours.q), np.zeros(3)) == 0))
        g_ours, tg_ours = best_of(3, lambda: lab_tip_load_gradient(arm, ours.q))  # noqa: B023
        g_sk, tg_sk = best_of(3, lambda: sk.tip_load_gradient(theirs))  # noqa: B023

        def tip_ours(F):
            return solve_static(lab_loaded_arm(fem, F), np.zeros(3)).p_tip_W

        fd_ours = (tip_ours(F_n + H_N) - tip_ours(F_n - H_N)) / (2 * H_N)
        fd_sk = (sk.solve(F_n + H_N).p_tip_W - sk.solve(F_n - H_N).p_tip_W) / (2 * H_N)
        dx = np.abs(theirs.x_W - arm.to_nodes(ours.q)).max()
        rows.append((what, ours, theirs, t_ours, t_sk, slack, dx, g_ours, g_sk, fd_ours, fd_sk, tg_ours, tg_sk))
        print(
            f"  scikit-fem: {what}: ours {1e3 * t_ours:.0f} ms ({ours.iterations} steps), scikit-fem "
            f"{1e3 * t_sk:.0f} ms ({theirs.iterations} Newton steps), largest node difference {1e3 * dx:.1e} mm",
            flush=True,
        )
    print(
        f"\n## The body alone in scikit-fem {skfem.__version__} (same mesh {fem.mesh.n_nodes} nodes, same "
        "neo-Hookean law, cables 1 cm slack), one thread, times best of 3\n"
    )
    row("load", "tip displacement ours / scikit-fem", "difference", "static solve from rest ours / scikit-fem")
    row("---", "---", "---", "---")
    for what, ours, theirs, t_ours, t_sk, slack, dx, *_ in rows:
        d_ours, d_sk = 1e3 * (ours.p_tip_W - p0), 1e3 * (theirs.p_tip_W - p0)
        row(
            what + ("" if slack else " (a cable taut!)"),
            f"{np.linalg.norm(d_ours):.4f} / {np.linalg.norm(d_sk):.4f} mm",
            f"{np.linalg.norm(d_sk - d_ours):.1e} mm (nodes: max {1e3 * dx:.1e} mm)",
            f"{1e3 * t_ours:.0f} ms / {1e3 * t_sk:.0f} ms ({t_sk / t_ours:.1f}x)",
        )
    print()
    row(
        "load",
        "d z_tip / d F: ours (Hessian solve) / scikit-fem (adjoint)",
        "central FD ours / scikit-fem",
        "largest rel. difference",
        "gradient time ours / scikit-fem",
    )
    row("---", "---", "---", "---", "---")
    for what, *_, g_ours, g_sk, fd_ours, fd_sk, tg_ours, tg_sk in rows:
        worst = max(np.abs(g - g_ours).max() for g in (g_sk, fd_ours, fd_sk)) / np.abs(g_ours).max()
        row(
            what,
            f"{1e3 * g_ours[2]:.4f} / {1e3 * g_sk[2]:.4f} mm/N",
            f"{1e3 * fd_ours[2]:.4f} / {1e3 * fd_sk[2]:.4f} mm/N",
            f"{worst:.1e} (all 3 components)",
            f"{1e3 * tg_ours:.1f} ms / {1e3 * tg_sk:.1f} ms",
        )
    print(
        "\nCables: not compared with scikit-fem, which has no one-sided cable (a tension-only spring along "
        "a routed path through the body); only slack-cable states are comparable. torch-fem: not run "
        "(every release with a hyperelastic material imports pyvista, which needs vtk, outside the pinned "
        "environment)."
    )


def row(*cells):
    print("| " + " | ".join(cells) + " |")


if args.only_skfem:
    print(f"mesh {fem.mesh.n_nodes} nodes, {len(fem.mesh.tets)} tets; only the scikit-fem section (--only-skfem)")
    skfem_section()
    raise SystemExit(0)
u_max = robot.u_max_rad
named = [("rest", np.zeros(3))] + [(f"cable {i} at u_max", u_max * np.eye(3)[i]) for i in range(3)]
named += [("mixed (0.5, 1) u_max", np.array([0.0, 0.5, 1.0]) * u_max)]
named += [(f"small: 0.1 rad + 0.3 on cable {i}", 0.1 + 0.3 * np.eye(3)[i]) for i in range(3)]
named += [(f"Sobol {i}", u) for i, u in enumerate(sobol_commands(robot, n_sobol, seed=0))]
labels, U = [n for n, _ in named], np.array([u for _, u in named])
small = np.array([lab.startswith("small") or lab == "rest" for lab in labels])
t0 = time.perf_counter()
arm = mujoco_arm(fem)
t_build = time.perf_counter() - t0
print(
    f"mesh {fem.mesh.n_nodes} nodes ({len(arm.free_nodes)} free), {len(fem.mesh.tets)} tets; MuJoCo model built in "
    f"{t_build:.2f} s: {arm.model.nv} dofs, timestep {arm.model.opt.timestep * 1e3:.2f} ms, integrator discrete, "
    f"flex damping {arm.model.flex_damping[0]:.3g} s; settled = every node below {V_TOL:g} m/s for {HOLD_S} s "
    f"(at most {MAX_SIM_S} s simulated)"
)

# ------------------------------------------------------------------ ours
solve_static(fem, U[1])  # first-call costs (imports, factorisation set-up) out of the timings
cold_ours, warm_ours, sens_ours, tips_ours, J_ours, q_prev, fails_ours = [], [], [], [], [], None, 0
for u in U:
    t0 = time.perf_counter()
    fails_ours += not solve_static(fem, u, raise_on_failure=False).converged
    cold_ours.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    sol = solve_static(fem, u, q_prev, raise_on_failure=False)
    warm_ours.append(time.perf_counter() - t0)
    fails_ours += not sol.converged
    q_prev = sol.q
    tips_ours.append(sol.p_tip_W)
    t0 = time.perf_counter()
    J_ours.append(sensitivities(fem, sol.q, u)[1])
    sens_ours.append(time.perf_counter() - t0)
tips_ours = np.array(tips_ours)

# ------------------------------------------------------------------ MuJoCo
runs = []


def settle(data, u):
    arm.set_command(u)
    r = arm.settle(data, v_tol_m_s=V_TOL, hold_s=HOLD_S, max_time_s=MAX_SIM_S)
    runs.append(r)
    return r


cold_mj, warm_mj, tips_mj, J_mj, jac_mj_s, chain = [], [], [], [], [], None
for i, u in enumerate(U):
    d = arm.new_data()
    cold_mj.append(settle(d, u))
    if chain is None:  # the chain starts from the settled rest state
        chain, warm_mj = d, [cold_mj[0]]
    else:
        warm_mj.append(settle(chain, u))
    tips_mj.append(arm.tip(chain))
    print(
        f"  {labels[i]:<26} MuJoCo cold {cold_mj[-1].status} {cold_mj[-1].wall_s:6.2f} s, warm "
        f"{warm_mj[-1].status} {warm_mj[-1].wall_s:6.2f} s; "
        f"tip distance {1e3 * np.linalg.norm(tips_mj[-1] - tips_ours[i]):.2f} mm",
        flush=True,
    )
    # Jacobians where every cable is pulled by more than H_RAD (no slack kink inside the
    # central difference): the small commands and the first Sobol one (one small with --quick).
    jac_here = labels[i] == "Sobol 0" or labels[i].startswith("small")
    if jac_here and not (args.quick and labels[i][-1] in "12"):
        cols, wall = [], 0.0
        for j in range(3):
            tip_pm = []
            for s in (1, -1):
                dj = copy.copy(chain)
                r = settle(dj, u + s * H_RAD * np.eye(3)[j])
                wall += r.wall_s
                tip_pm.append(arm.tip(dj))
            cols.append((tip_pm[0] - tip_pm[1]) / (2 * H_RAD))
        arm.set_command(u)
        J_mj.append((i, np.array(cols).T))
        jac_mj_s.append(wall)
tips_mj = np.array(tips_mj)
dist = np.linalg.norm(tips_mj - tips_ours, axis=1)
statuses = [r.status for r in runs]
print("\ncommand                    ours tip (mm)              MuJoCo tip (mm)            distance mm")
for lab, a, b, dd in zip(labels, tips_ours, tips_mj, dist):
    print(
        f"{lab:<26} {np.array2string(1e3 * a, precision=1):<26} "
        f"{np.array2string(1e3 * b, precision=1):<26} {1e3 * dd:7.2f}"
    )
J_err = [np.linalg.norm(Jm - J_ours[i]) / np.linalg.norm(J_ours[i]) for i, Jm in J_mj]


# ------------------------------------------------------------------ the material alone
# Cables 1 cm slack (no cable force): gravity sag, then a downward tip load on top, added to
# our external load vector (gravity's) and as MuJoCo's applied force on the tip node's body.
mat_rows = []
for what, F_n in (("gravity sag", 0.0), ("gravity + 5 mN tip load", 5e-3), ("gravity + 50 mN tip load", 50e-3)):
    f = ArmFEM(robot, fem.mesh, cable_slack_m=[0.01] * 3)
    tip_node = f.tip_nodes[np.argmax(f.tip_weights)]
    f.f_gravity_W = f.f_gravity_W.copy()
    f.f_gravity_W[tip_node, 2] -= F_n
    t0 = time.perf_counter()
    sol = solve_static(f, np.zeros(3))
    t_ours = time.perf_counter() - t0
    a = mujoco_arm(f)
    d = a.new_data()
    d.xfrc_applied[1 + int(np.flatnonzero(a.free_nodes == tip_node)[0]), 2] = -F_n
    r = a.settle(d, v_tol_m_s=V_TOL, hold_s=HOLD_S, max_time_s=MAX_SIM_S)
    p0 = f.tip(f.X_W)
    mat_rows.append((what, 1e3 * (sol.p_tip_W - p0), 1e3 * (a.tip(d) - p0), t_ours, r))
    print(f"  material: {what}: ours {1e3 * t_ours:.0f} ms, MuJoCo {r.status} {r.wall_s:.2f} s", flush=True)

# ------------------------------------------------------------------ IK
model = load_model(args.model)
commands = CommandSet.from_robot(robot)
targets = circle(n_targets)
lm = IKSolver(model, commands, IKConfig("lm"), seeds=grid_seeds(model, commands, 7))
u_start = lm.initial_guess(targets[0])
bounds = (commands.lo, commands.hi)


def ours_ik(t, u):
    r = lm.solve(t, u0=u)
    return r.u_motor


def trf(tol):
    """least_squares with xtol = ftol = gtol = tol (SciPy's default: 1e-8)."""

    def solve(t, u):
        f = lambda v: model.predict(v) - t  # noqa: E731
        return least_squares(f, np.clip(u, *bounds), jac=model.jacobian, bounds=bounds, method="trf",
                             xtol=tol, ftol=tol, gtol=tol).x  # fmt: skip

    return solve


def lbfgsb(ftol, gtol):
    """L-BFGS-B on 1/2 |y(u) - y'|^2 (m^2) with the gradient J^T r (SciPy's defaults: 2.2e-9, 1e-5)."""

    def solve(t, u):
        def f(v):
            y, J = model.predict_and_jacobian(v)
            r = y - t
            return 0.5 * r @ r, J.T @ r

        options = {"ftol": ftol, "gtol": gtol, "maxiter": 2000}
        return minimize(f, u, jac=True, method="L-BFGS-B", bounds=list(zip(*bounds)), options=options).x

    return solve


# SciPy at its default tolerances, at the loosest ones that reach our residual (~2e-9 m;
# found by trying 1e-8, 1e-10, 1e-12 and (ftol, gtol) = defaults, (1e-20, 1e-11), (1e-30, 1e-13)),
# and tight. The ratios of the goal use the "equal residual" rows.
SOLVERS = [
    ("lab bounded LM (tol 1e-8 m)", ours_ik),
    ("SciPy trf, default tolerances", trf(1e-8)),
    ("SciPy trf, equal residual (tol 1e-10)", trf(1e-10)),
    ("SciPy trf, tight (tol 1e-12)", trf(1e-12)),
    ("SciPy L-BFGS-B, default tolerances", lbfgsb(2.220446049250313e-09, 1e-5)),
    ("SciPy L-BFGS-B, equal residual (1e-20, 1e-11)", lbfgsb(1e-20, 1e-11)),
    ("SciPy L-BFGS-B, tight (1e-30, 1e-13)", lbfgsb(1e-30, 1e-13)),
]
ik_rows = []
for name, fn in SOLVERS:
    best = None
    for _ in range(3):
        u, per, res, unsafe = u_start, [], [], 0
        for t in targets:
            t0 = time.perf_counter()
            u = fn(t, u)
            per.append(time.perf_counter() - t0)
            res.append(np.linalg.norm(model.predict(u) - t))
            unsafe += not commands.contains(u, 1e-9)
        if best is None or np.mean(per) < np.mean(best[0]):
            best = (per, np.array(res), unsafe)
    ik_rows.append(
        (name, 1e3 * np.mean(best[0]), best[1].max(), np.median(best[1]), int((best[1] > REACH_M).sum()), best[2])
    )


# ------------------------------------------------------------------ the table
def mean_of(results, key):
    return float(np.mean([getattr(r, key) for r in results])) if results else float("nan")


ok = [r for r in cold_mj if r.status == "settled"]
okw = [r for r in warm_mj[1:] if r.status == "settled"]
c_ours, w_ours, s_ours = np.mean(cold_ours), np.mean(warm_ours[1:]), np.mean(sens_ours)
c_mj, w_mj = mean_of(ok, "wall_s"), mean_of(okw, "wall_s")
n_bad = sum(s != "settled" for s in statuses)
print(f"\n## Peers: {len(U)} commands ({small.sum()} rest or small), mesh {fem.mesh.n_nodes} nodes, one thread\n")
row("quantity", "ours (lab FEM)", "MuJoCo 4.0.0", "ratio")
row("---", "---", "---", "---")
row(
    "tip distance to ours, all commands (median / max)",
    "-",
    f"{1e3 * np.median(dist):.2f} / {1e3 * dist.max():.2f} mm",
    "",
)
row("tip distance, rest and small commands (max)", "-", f"{1e3 * dist[small].max():.2f} mm", "")
row(
    "static equilibrium from rest (mean)",
    f"{1e3 * c_ours:.1f} ms",
    f"{c_mj:.2f} s ({mean_of(ok, 'sim_time_s'):.2f} s simulated)",
    f"{c_mj / c_ours:.0f}x",
)
row(
    "from the previous command's state (mean)",
    f"{1e3 * w_ours:.1f} ms",
    f"{w_mj:.2f} s ({mean_of(okw, 'sim_time_s'):.2f} s simulated)",
    f"{w_mj / w_ours:.0f}x",
)
if J_mj:
    j_mj = float(np.mean(jac_mj_s))
    row(
        f"tip Jacobian (3x3) at {len(J_mj)} commands (mean)",
        f"{1e3 * s_ours:.1f} ms (sensitivity)",
        f"{j_mj:.1f} s (6 settles)",
        f"{j_mj / s_ours:.0f}x",
    )
    row("Jacobian difference, rel. Frobenius (median / max)", "-", f"{np.median(J_err):.2f} / {max(J_err):.2f}", "")
row(
    "runs unstable / not settled",
    f"{fails_ours} of {2 * len(U)} solves failed",
    f"{statuses.count('unstable')} / {statuses.count('not_settled')} of {len(runs)} ({100 * n_bad / len(runs):.0f} %)",
    "",
)
row("runs with MuJoCo warnings (ill-conditioned M + K)", "-", f"{sum(r.warnings > 0 for r in runs)} of {len(runs)}", "")
print("\n## The material alone (cables slack): tip displacement\n")
row("load", "ours (neo-Hookean)", "MuJoCo flex", "difference", "time ours / MuJoCo")
row("---", "---", "---", "---", "---")
for what, d_ours, d_mj, t_ours, r in mat_rows:
    row(
        what,
        f"{np.linalg.norm(d_ours):.2f} mm",
        f"{np.linalg.norm(d_mj):.2f} mm ({r.status})",
        f"{np.linalg.norm(d_mj - d_ours):.3f} mm",
        f"{1e3 * t_ours:.0f} ms / {r.wall_s:.2f} s",
    )
print(
    "\ntorch-fem: not run. Every release with a hyperelastic material (0.4 to 0.14.0) imports pyvista "
    "at `import torchfem`, which needs vtk (a 140 MB wheel) outside the pinned environment; 0.3.8 has "
    "only small-strain materials. The cables have no counterpart there either."
)
if not args.skip_skfem:
    skfem_section()
print(f"\n## IK: learned model, circle of {n_targets} targets, warm-started, best of 3 passes\n")
row("solver", "ms per target", "max / median residual", "failures (> 10 um)", "outside the safety rule")
row("---", "---", "---", "---", "---")
for name, t_ms, rmax, rmed, fails, unsafe in ik_rows:
    row(name, f"{t_ms:.3f}", f"{rmax:.1e} / {rmed:.1e} m", str(fails), str(unsafe))
print(
    f"\nratios: MuJoCo settle / our static solve = {c_mj / c_ours:.0f}x from rest, {w_mj / w_ours:.0f}x warm "
    f"(goal >= 10x); SciPy / lab IK at equal residual = {ik_rows[2][1] / ik_rows[0][1]:.1f}x (trf), "
    f"{ik_rows[5][1] / ik_rows[0][1]:.1f}x (L-BFGS-B) (goal >= 3x)"
)
