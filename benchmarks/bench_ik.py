"""IK time per target point along a trajectory: learned model vs Soft IK (FEM in the loop).

    python benchmarks/bench_ik.py                 # circle, 100 points, default mesh (~1 minute)
    python benchmarks/bench_ik.py --trajectory rose --n-points 50

Both solve the same targets in one run, each warm-started from the previous solution
(Section II-D) with the bounded Levenberg-Marquardt solver; the learned model's cold
start is seeded from a 7^3 grid of its predictions, Soft IK starts at the centre of the
command set. The learned-model timing is the best of 5 passes (the target is < 1 ms per
point); Soft IK runs once. Also shown: projected gradient descent (the paper's
minimiser) through the learned model, and the ratio Soft IK / learned model.
"""

import argparse
import os
import time

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik import IKConfig, IKSolver, grid_seeds
from lab.control.soft_ik import FEMForwardMap
from lab.control.trajectories import BUILTIN, load_trajectory
from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.learn.mlp import load_model

ap = argparse.ArgumentParser()
ap.add_argument("--model", default="data/model_sim_three_cable.npz")
ap.add_argument("--trajectory", default="circle", help=f"{', '.join(BUILTIN)} or a CSV file")
ap.add_argument("--n-points", type=int, default=100)
args = ap.parse_args()
print(f"threads per process: OMP={os.environ.get('OMP_NUM_THREADS')} MKL={os.environ.get('MKL_NUM_THREADS')}")

robot = load_robot("three-cable")
commands = CommandSet.from_robot(robot)
targets = load_trajectory(args.trajectory, None if args.trajectory.endswith(".csv") else args.n_points)
model = load_model(args.model)
print(f"{args.trajectory}: {len(targets)} targets; model {model!r} from {args.model}")


def summary(name, run, wall_s):
    per = run.time_s
    print(
        f"  {name:<28} {1e3 * np.mean(per):9.3f} ms/target (median {1e3 * np.median(per):.3f}, max "
        f"{1e3 * np.max(per):.3f}), {run.iterations.mean():.2f} iterations/target, "
        f"max residual {run.residual_m.max():.1e} m, {int(run.reachable.sum())}/{len(per)} reached, "
        f"{wall_s:.2f} s in all"
    )
    return float(np.mean(per))


print("\nlearned model (network Jacobian):")
lm = IKSolver(model, commands, IKConfig("lm"), seeds=grid_seeds(model, commands, 7))
best = None
for _ in range(5):
    t0 = time.perf_counter()
    run = lm.follow(targets)
    wall = time.perf_counter() - t0
    if best is None or np.mean(run.time_s) < np.mean(best[0].time_s):
        best = (run, wall)
t_model = summary("LM, warm-started", *best)
t0 = time.perf_counter()
warm_gd = IKSolver(model, commands, IKConfig("gd"), seeds=grid_seeds(model, commands, 7)).follow(targets)
t_gd = summary("gradient descent, warm", warm_gd, time.perf_counter() - t0)

print("\nSoft IK (FEM statics + sensitivity analysis, default mesh):")
fem = ArmFEM(robot)
print(f"  mesh: {fem.mesh.n_nodes} nodes, {len(fem.mesh.tets)} tets")
fmap = FEMForwardMap(fem)
t0 = time.perf_counter()
soft = IKSolver(fmap, commands, IKConfig("lm")).follow(targets)
t_soft = summary("LM, warm-started", soft, time.perf_counter() - t0)
print(
    f"  {fmap.n_solves} static solves ({fmap.n_solves / len(targets):.2f} per target), "
    f"{1e3 * fmap.solve_time_s / fmap.n_solves:.1f} ms each"
)

du = np.abs(soft.u_motor - best[0].u_motor).max()
print(
    f"\nlearned model LM: {1e3 * t_model:.3f} ms per target (target < 1 ms); gradient descent "
    f"{1e3 * t_gd:.2f} ms ({t_gd / t_model:.0f}x LM)"
)
print(f"Soft IK: {1e3 * t_soft:.1f} ms per target; ratio Soft IK / learned model = {t_soft / t_model:.0f}x")
print(f"largest command difference between the two: {du:.4f} rad")
