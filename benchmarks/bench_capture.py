"""Capture rate per protocol, and the latency of one closed-loop correction (chapter 09).

    python benchmarks/bench_capture.py [--n 100] [--robots shipped random:1 ...] [--quick]

1. **Twin, virtual clock.** The same ``--n`` random allowed commands captured on each
   emulated as-built robot (the shipped defects and members of the family) with the
   waiting protocol (the paper's, settle tolerance 0.1 mm) and the predictive one
   (``capture --protocol predictive``, default tolerance); samples per hour of robot time
   (learning samples included, and after the learning phase), mean and maximum distance
   from the robot's noise-free settled tips. Then both protocols at several tolerances on
   the shipped robot: the rate-against-error curve of chapter 09. All rows go to
   ``data/capture_rate.csv`` (+ ``.json`` with this command line).
2. **The 308-sample grid captures** ``data/real_three_cable.csv`` (waiting) and
   ``data/real_three_cable_predictive.csv`` (predictive): rate from their metadata, error
   against the noise-free settled tips.
3. **Emulators, real clock.** The hardware path (dynamixel-sdk and the NatNet client against
   the emulated XM430 bus and NatNet server, driving the as-built body on a coarse mesh,
   shipped lag constants) in wall-clock time: a few samples per protocol, the predictive
   one with the relaxation learned in part 1.
4. **Correction latency.** Computing one closed-loop correction (the network's Jacobian, the
   damped step restricted to the allowed commands) in wall time, and the robot time one
   per-target feedback iteration costs (settle + averaging window) on the twin.

Ratios compare protocols measured in this run. One thread per process.
"""

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from timing import best_of

from lab.description import load_robot
from lab.studies.capture_rate import capture_rate_study, write_capture_rate

ROOT = Path(__file__).resolve().parent.parent


def part1(robot, args):
    print(f"\n1. twin, virtual clock: {args.n} random allowed commands per robot")
    mesh = {"n_rings": 2, "n_axial": 8} if args.quick else {}
    rows = capture_rate_study(robot, args.robots, n_samples=args.n, mesh=mesh, seed=args.seed)
    print(
        f"{'robot':>10} {'protocol':>10} {'per hour':>9} {'after learning':>15} {'mean mm':>8} {'max mm':>7}"
        "  learned tau (s), w"
    )
    for r in rows:
        learned = (
            f"{r['tau_fast_s']:.2f}/{r['tau_slow_s']:.2f}, {r['slow_fraction']:.2f} "
            f"(true {r['true_tau_fast_s']:.2f}/{r['true_tau_slow_s']:.2f}, {r['true_slow_fraction']:.2f})"
            if r["protocol"] == "predictive"
            else ""
        )
        print(
            f"{r['robot']:>10} {r['protocol']:>10} {r['rate_per_hour']:9.0f} {r['rate_after_learning_per_hour']:15.0f} "
            f"{1e3 * r['mean_error_m']:8.3f} {1e3 * r['max_error_m']:7.3f}  "
            f"after learning {1e3 * r['mean_error_after_learning_m']:.3f} mm  {learned}"
        )
    for label in args.robots:
        w, p = (next(r for r in rows if r["robot"] == label and r["protocol"] == k) for k in ("wait", "predictive"))
        print(
            f"{label}: predictive / wait = {p['rate_per_hour'] / w['rate_per_hour']:.2f}x per hour "
            f"({p['rate_after_learning_per_hour'] / w['rate_per_hour']:.2f}x after learning)"
        )
    sweep = capture_rate_study(
        robot,
        ("shipped",),
        n_samples=args.n,
        mesh=mesh,
        seed=args.seed,
        wait_tols_m=(5e-5, 2e-4, 4e-4),
        predict_tols_m=(5e-5, 1e-4, 2.5e-4, 4e-4),
    )
    print("tolerance sweep (shipped): protocol, tol mm -> per hour (after learning), mean error mm (after learning)")
    for r in sweep:
        print(
            f"  {r['protocol']:>10} {1e3 * r['tol_m']:5.2f} -> {r['rate_per_hour']:6.0f} "
            f"({r['rate_after_learning_per_hour']:6.0f}), {1e3 * r['mean_error_m']:.3f} "
            f"({1e3 * r['mean_error_after_learning_m']:.3f})"
        )
    return rows + sweep


def part2(robot):
    from lab.data.dataset import read_dataset
    from lab.rig.twin import AsBuiltBody

    print("\n2. the 308-sample grid captures on the shipped emulated as-built robot (default mesh)")
    body = AsBuiltBody(robot)
    truth = None
    for name in ("real_three_cable.csv", "real_three_cable_predictive.csv"):
        path = ROOT / "data" / name
        if not path.exists():
            print(f"  {name}: missing (its command is in data/README.md)")
            continue
        u, y, meta = read_dataset(path)
        if truth is None:
            truth = np.array([body.quasi_static_tip(ui) for ui in u])
        err = np.linalg.norm(y - truth, axis=1)
        print(
            f"  {name}: {meta['capture']['rate_samples_per_hour']:.0f} samples per hour of robot time, "
            f"{meta['protocol'].get('kind', 'wait')}; error against the settled truth mean {1e3 * err.mean():.3f} mm, "
            f"max {1e3 * err.max():.3f} mm"
        )


def part3(robot, relax, n):
    from lab.capture.protocol import Protocol
    from lab.capture.session import capture
    from lab.data.designs import random_commands
    from lab.rig.emulators import EmulatedBench
    from lab.rig.hardware import HardwareRig
    from lab.rig.twin import AsBuiltBody

    print(f"\n3. emulators, real clock: {n} samples per protocol through dynamixel-sdk + NatNet")
    u = random_commands(robot, n, seed=11)
    for kind in ("wait", "predictive"):
        body = AsBuiltBody(robot, n_rings=2, n_axial=8)
        protocol = Protocol() if kind == "wait" else Protocol(kind="predictive")
        with tempfile.TemporaryDirectory() as tmp, EmulatedBench(robot, body, noise_m=1.5e-4) as bench:
            with HardwareRig.from_config(bench.write_config(Path(tmp) / "rig.toml"), robot) as rig:
                t0 = time.perf_counter()
                res = capture(rig, u, Path(tmp) / "j.csv", protocol, relaxation=relax if kind != "wait" else None)
                wall = time.perf_counter() - t0
        truth = np.array([body.quasi_static_tip(ui) for ui in u])
        err = np.linalg.norm(res.p_tip_W - truth, axis=1)
        print(
            f"  {kind:>10}: {3600 * n / wall:6.0f} samples per hour of wall clock ({res.rate_per_hour:.0f} by the rig "
            f"clock), mean error {1e3 * err.mean():.3f} mm"
        )


def part4(robot):
    from lab.control.ik import IKSolver
    from lab.control.trajectories import builtin
    from lab.learn.models import load_model
    from lab.rig.twin import AsBuiltBody, TwinRig
    from lab.tracking.closed_loop import Correction, correct_command, run_closed_loop

    print("\n4. closed-loop correction latency (model data/model_real_three_cable.npz, circle)")
    model = load_model(ROOT / "data" / "model_real_three_cable.npz")
    solver = IKSolver.for_model(model, robot)
    targets = builtin("circle", 12)
    u0 = np.full(robot.n_cables, 0.8)
    measured = targets[0] + 1e-3
    s = best_of(lambda: correct_command(solver.commands, solver.forward, u0, targets[0], measured), n=50)
    print(f"  computing one correction: {1e3 * s:.3f} ms (best of 50, wall)")
    body = AsBuiltBody(robot, n_rings=2, n_axial=8)
    res = run_closed_loop(
        TwinRig(robot, body=body), solver, targets, mode="feedback", passes=2, correction=Correction()
    )
    per = np.mean(res.settle_wait_s) + Correction().window_s
    print(
        f"  one feedback iteration on the twin: {per:.2f} s of robot time "
        f"(settle {np.mean(res.settle_wait_s):.2f} s + window)"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="commands per robot and protocol (part 1)")
    ap.add_argument("--robots", nargs="+", default=["shipped", "random:1", "random:2", "random:3", "random:4"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hardware-samples", type=int, default=4, help="samples per protocol on the emulators (part 3)")
    ap.add_argument("--out", default=str(ROOT / "data" / "capture_rate.csv"), help="rows of part 1")
    ap.add_argument("--quick", action="store_true", help="coarse meshes, for trying the script")
    args = ap.parse_args()
    print(f"threads per process: OMP={os.environ.get('OMP_NUM_THREADS')} MKL={os.environ.get('MKL_NUM_THREADS')}")
    robot = load_robot("three-cable")
    rows = part1(robot, args)
    write_capture_rate(args.out, rows, "python benchmarks/bench_capture.py " + " ".join(sys.argv[1:]))
    print(f"-> {args.out}")
    from lab.dynamics.relaxation import Relaxation

    r = next(r for r in rows if r["robot"] == "shipped" and r["protocol"] == "predictive")
    relax = Relaxation([r["tau_fast_s"], r["tau_slow_s"]], [1 - r["slow_fraction"], r["slow_fraction"]], 1.5e-4)
    part2(robot)
    part3(robot, relax, args.hardware_samples)
    part4(robot)


if __name__ == "__main__":
    main()
