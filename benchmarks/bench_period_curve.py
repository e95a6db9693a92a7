"""Trajectories at speed (issue 16, item 3): streamed error against the period, open loop and feed-forward.

    python benchmarks/bench_period_curve.py --model data/model_real_three_cable.npz \
        --rig twin=data/dynamics_three_cable_twin.npz \
        --rig twin:random:1=data/dynamics_three_cable_random1.npz ... \
        --periods 2 3 5 8 12 20 --out data/period_curve.csv [--traces 5 --traces-dir data]

For each ``--rig SPEC=DYN.npz[=MODEL.npz]`` (a rig spec of ``--rig``, the dynamic model that
``python -m lab fit-dynamics`` fitted on it, and the quasi-static model to solve the IK
through, default ``--model``) and period, the trajectory is streamed on a fresh rig open
loop and with the feed-forward (:mod:`lab.tracking.stream`); one row each
(:mod:`lab.studies.period_curve`). With ``--traces T``, what the tip did over the last
period of the first rig's two runs at period ``T`` is written to ``stream_TRAJ_T{T}.csv`` in
``--traces-dir`` (:func:`lab.studies.period_curve.write_traces`, for the drawn-trajectory figure).
"""

import argparse
import shlex
import sys
import time
from pathlib import Path

from lab.control.ik import IKSolver
from lab.control.trajectories import load_trajectory
from lab.description import load_robot
from lab.dynamics.relaxation import load_relaxation
from lab.learn import load_model
from lab.rig import make_rig
from lab.studies.period_curve import period_curve_rows, write_period_curve, write_traces

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--model", default="data/model_real_three_cable.npz", help="quasi-static model (.npz)")
parser.add_argument("--robot", default="three-cable")
parser.add_argument("--trajectory", default="circle")
parser.add_argument("--rig", action="append", required=True, metavar="SPEC=DYN.npz[=MODEL.npz]")
parser.add_argument("--periods", type=float, nargs="+", default=[2, 3, 5, 8, 12, 20])
parser.add_argument("--seed", type=int, default=0, help="noise seed of the emulated rigs")
parser.add_argument("--out", required=True)
parser.add_argument("--traces", type=float, help="period whose two results to keep (first rig)")
parser.add_argument("--traces-dir", default="data")
args = parser.parse_args()

robot = load_robot(args.robot)
targets = load_trajectory(args.trajectory)
solvers, runs = {}, []
for item in args.rig:
    spec, dyn, *model = item.split("=")
    model_path = model[0] if model else args.model
    if model_path not in solvers:
        solvers[model_path] = IKSolver.for_model(load_model(model_path), robot)
    runs.append((spec, Path(model_path).name, solvers[model_path], load_relaxation(dyn)))
t0 = time.perf_counter()
rows, results = period_curve_rows(
    lambda spec: make_rig(spec, robot, seed=args.seed),
    runs,
    targets,
    args.periods,
    log=lambda line: print(line, file=sys.stderr, flush=True),
)
command = "python benchmarks/bench_period_curve.py " + shlex.join(sys.argv[1:])
write_period_curve(
    args.out,
    rows,
    {
        "command": command,
        "model": args.model,
        "trajectory": args.trajectory,
        "runs": args.rig,
        "wall_s": time.perf_counter() - t0,
    },
)
if args.traces is not None:
    first = runs[0]
    traces = {mode: results[(first[0], first[1], float(args.traces), mode)] for mode in ("open-loop", "feed-forward")}
    write_traces(Path(args.traces_dir) / f"stream_{args.trajectory}_T{args.traces:g}.csv", traces)
print(f"{len(rows)} rows -> {args.out} in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
