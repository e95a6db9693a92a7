"""Speed of each forward model of chapter 08 side by side: training, prediction, and IK per target.

    python benchmarks/bench_models.py [--data data/sim_three_cable.csv] [--members 5]

For each model of ``python -m lab train --model`` (lab's MLP by LM, the same by Bayesian
regularisation, a deep ensemble of K MLPs, scikit-learn's GaussianProcessRegressor,
KNeighborsRegressor and MLPRegressor, and the direct inverse u = g(y)), fitted on all of the
dataset (one thread, as everywhere here), it prints:

* the training time (s);
* the prediction time of a batch of 10,000 commands and of one command with its Jacobian
  (best of several repetitions);
* the IK time per target along the Table I circle (24 targets, warm-started, through
  ``lab.control.ik.IKSolver.for_model``: bounded LM through the exact Jacobian, or the derivative-free
  IK (secant LM + compass poll) for a model without one, which the output says), the IK's residual on the
  model (how well it inverted its own model, m) and the targets flagged unreachable. The
  direct inverse has no IK: one ``command(y)`` evaluation per target.

All ratios are against lab's MLP (LM) measured in the same run.
"""

import argparse
import os
import time
from pathlib import Path

import numpy as np
from timing import best_of

from lab.control.ik import IKSolver
from lab.control.trajectories import builtin
from lab.data.dataset import read_dataset
from lab.description import load_robot
from lab.learn.model_specs import model_spec
from lab.learn.models import fit_model

ROOT = Path(__file__).resolve().parent.parent
MODELS = [
    ("mlp (LM)", "mlp", {}),
    ("mlp (BR)", "mlp", {"algorithm": "br"}),
    ("ensemble (LM)", "ensemble", {}),
    ("gpr", "gpr", {}),
    ("knn", "knn", {}),
    ("sklearn-mlp", "sklearn-mlp", {}),
    ("inverse-mlp", "inverse-mlp", {}),
]

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--data", default=str(ROOT / "data" / "sim_three_cable.csv"))
parser.add_argument("--robot", default="three-cable")
parser.add_argument("--members", type=int, default=5, help="ensemble members K (default 5)")
args = parser.parse_args()

print(f"threads per process: OMP={os.environ.get('OMP_NUM_THREADS')} MKL={os.environ.get('MKL_NUM_THREADS')}")
robot = load_robot(args.robot)
u, y, _ = read_dataset(args.data)
targets = builtin("circle", 24)
U = np.random.default_rng(0).uniform(0.0, robot.u_max_rad, (10_000, robot.n_cables))
print(f"{Path(args.data).name}: {len(u)} samples; IK along the circle, {len(targets)} targets\n")
header = (
    f"{'model':<15}{'train s':>9}{'10k predict ms':>16}{'1 pred+J us':>13}{'IK ms/target':>14}"
    f"{'IK resid um':>13}{'unreach':>9}{'Jacobian':>10}  IK"
)
print(header)
print("-" * len(header))
ref = {}
for label, name, kw in MODELS:
    t0 = time.perf_counter()
    model = fit_model(model_spec(name, members=args.members, **kw), u, y)
    train_s = time.perf_counter() - t0
    if name == "inverse-mlp":
        t_batch = best_of(lambda m=model: m.command(targets), 20) / len(targets) * 10_000
        t_ik = best_of(lambda m=model: [m.command(p) for p in targets], 5) / len(targets)
        print(
            f"{label:<15}{train_s:9.2f}{1e3 * t_batch:16.2f}{'-':>13}{1e3 * t_ik:14.3f}{'-':>13}{'-':>9}"
            f"{'none':>10}  none: u = g(y), one evaluation"
        )
        continue
    t_batch = best_of(lambda m=model: m.predict(U), 5)
    has_j = getattr(model, "has_jacobian", True)
    t_one = best_of(lambda m=model: m.predict_and_jacobian(U[0]), 200) if has_j else float("nan")
    solver = IKSolver.for_model(model, robot)
    t0 = time.perf_counter()
    plan = solver.follow(targets)
    t_ik = (time.perf_counter() - t0) / len(targets)
    resid = np.linalg.norm(model.predict(plan.u_motor) - targets, axis=1)
    ik_kind = "bounded LM, exact Jacobian" if has_j else "derivative-free (secant LM + compass poll)"
    ref.setdefault("train", train_s)
    ref.setdefault("ik", t_ik)
    print(
        f"{label:<15}{train_s:9.2f}{1e3 * t_batch:16.2f}{1e6 * t_one:13.1f}{1e3 * t_ik:14.3f}"
        f"{1e6 * np.mean(resid):13.2f}{int((~plan.reachable).sum()):9d}{'exact' if has_j else 'none':>10}  "
        f"{ik_kind} (train x{train_s / ref['train']:.1f}, IK x{t_ik / ref['ik']:.1f} of mlp LM)"
    )
